"""V_max inputs from a fleet's per-type ratio k = c_y / C_xr, for a set measured driving straight.

A fleet whose fit learnt the ratio (:func:`tyrebayes.inference.fleet.lateral_ratio_draws`) gives a
set of the type C_y = k · C_xr with k drawn from the type's posterior predictive in place of the
fixed k_type; μ_y stays the type relation's.
"""

from __future__ import annotations

import jax
import numpy as np
from jaxtyping import Array

from ..fleet.predict import lateral_ratio_draws, lateral_sets_per_type
from ..result import Fit
from .inputs import TYPE_SURFACE, VmaxInputs
from .type_relations import K_TYPE, lateral_draws


def fleet_ratio_vmax_inputs(
    key: Array, fleet: Fit, c_xr, tyre_type: str, n: int, note: str = ""
) -> VmaxInputs:
    """Draws of C_y = k · C_xr on both axles with k from the fleet's ratio for the type.

    k is the fleet fit's posterior predictive for a new set of the type
    (:func:`tyrebayes.inference.fleet.lateral_ratio_draws`: the type's median ratio with its
    uncertainty and the set-to-set scatter); μ_y is the type relation's (0.95 μ_type), as in
    :func:`type_vmax_inputs`.

    Parameters
    ----------
    key : jax.Array
        PRNG key.
    fleet : Fit
        A fleet fit with the lateral ratio (a fleet table with ``c_y``).
    c_xr : float or array_like
        The set's C_xr [-]: a value, or its fit's posterior draws (resampled with replacement).
    tyre_type : str
        One of ``winter``, ``all_season``, ``summer``.
    n : int
        Number of draws.
    note : str
        Why no measured lateral posterior (carried into the result, with the ratio's sets).

    Returns
    -------
    VmaxInputs
        ``lateral_source`` ``"fleet_type_ratio"``, ``mu_y_source`` ``"type_prior"``.

    Examples
    --------
    >>> x = fleet_ratio_vmax_inputs(key, fleet_fit, 30.0, "winter", 400)  # doctest: +SKIP
    >>> x.lateral_source  # doctest: +SKIP
    'fleet_type_ratio'
    """
    if tyre_type not in K_TYPE:
        raise ValueError(f"tyre_type: expected one of {tuple(K_TYPE)}, got {tyre_type!r}")
    k_k, k_mu, k_c = jax.random.split(key, 3)
    seed = int(jax.random.randint(k_k, (), 0, 2**31 - 1))
    k_ratio = lateral_ratio_draws(fleet, tyre_type, n, seed=seed)
    _, mu_y = lateral_draws(k_mu, 1.0, tyre_type, n)
    c = np.atleast_1d(np.asarray(c_xr, float))
    c_draws = c[np.asarray(jax.random.randint(k_c, (n,), 0, c.size))]
    c_y = k_ratio * c_draws
    sets = lateral_sets_per_type(fleet).get(tyre_type, 0)
    learnt = (
        f"k = c_y / C_xr from the fleet's {sets} {tyre_type} set(s) with a lateral estimate"
        if sets
        else f"k = c_y / C_xr: the fleet had no {tyre_type} set with a lateral estimate (prior)"
    )
    note = f"{note}; {learnt}" if note else learnt
    return VmaxInputs(
        c_y, c_y, np.asarray(mu_y), "fleet_type_ratio", "type_prior", TYPE_SURFACE, note
    )
