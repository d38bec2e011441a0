"""The V_max inputs of a per-tyre fit: its lateral posterior, else a fleet ratio, else the types."""

from __future__ import annotations

from jaxtyping import Array

from ..fleet.predict import has_lateral_ratio
from ..result import Fit
from ..tyre.result import TyreFit
from .fleet_ratio import fleet_ratio_vmax_inputs
from .inputs import VmaxInputs
from .lateral import lateral_vmax_inputs
from .type_relations import type_vmax_inputs


def fit_vmax_inputs(
    fit: TyreFit,
    key: Array,
    n: int,
    tyre_type: str = "all_season",
    *,
    fleet: Fit | None = None,
) -> VmaxInputs:
    """The V_max inputs of a per-tyre fit: its lateral posterior if it has one, else the types'.

    A converged and adequate lateral posterior gives :func:`lateral_vmax_inputs` (with the
    fit's μ_max on its first surface, observed or its prior there, where the lateral fit did
    not observe μ_y);
    otherwise, given a fleet fit that learnt the per-type ratio c_y / C_xr, that ratio at the
    fit's C_xr draws (:func:`fleet_ratio_vmax_inputs`), else the type relations there
    (:func:`type_vmax_inputs`), with the reason in ``note`` (the fit's ``lateral_reason``, or
    :meth:`LateralFit.unusable_reason`).

    Parameters
    ----------
    fit : TyreFit
        A per-tyre fit (``fit-tyre --out``, read with ``TyreFit.from_fit(load_fit(path))``).
    key : jax.Array
        PRNG key.
    n : int
        Number of draws.
    tyre_type : str
        The tyre type of the type relations (used only without a lateral posterior).
    fleet : Fit, optional
        A fleet fit (:func:`tyrebayes.fit_fleet`); used only without a lateral posterior, and
        only where it carries the lateral ratio.

    Returns
    -------
    VmaxInputs

    Examples
    --------
    >>> inputs = fit_vmax_inputs(tyre_fit, key, 400, "winter", fleet=fleet_fit)  # doctest: +SKIP
    >>> inputs.lateral_source  # doctest: +SKIP
    'fleet_type_ratio'
    """
    lateral = fit.lateral
    surface = str(fit.surfaces[0])
    if lateral is not None and not lateral.unusable_reason():
        return lateral_vmax_inputs(
            key,
            lateral,
            n,
            mu_max=fit.draws("mu_max")[:, 0],
            mu_max_observed=bool(fit.mu_observed.get(surface, False)),
            surface=surface,
        )
    if lateral is not None:
        why = lateral.unusable_reason()
    else:
        why = fit.lateral_reason or "the fit carries no lateral posterior"
    if fleet is not None and has_lateral_ratio(fleet):
        return fleet_ratio_vmax_inputs(key, fleet, fit.draws("c_xr"), tyre_type, n, note=why)
    return type_vmax_inputs(key, fit.draws("c_xr"), tyre_type, n, note=why)
