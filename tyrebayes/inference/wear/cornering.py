"""The cornering stiffness behind the wear evidence's lateral work, from a lateral posterior.

The lateral friction work W_y = ∫ F_y V_x tan α dt (thesis eq. 4.19b) needs each axle's slip
angle, which the forces alone do not give: it takes the axle's cornering stiffness c_y. Where a
lateral fit of the car exists (:func:`~tyrebayes.inference.lateral.fit.fit_lateral`, or the
``lateral`` part of a tyre fit), :func:`cornering_stiffness_from_lateral` turns its per-axle c_y
posterior into the :class:`~tyrebayes.streams.cornering_stiffness.CorneringStiffness` that
:func:`~tyrebayes.streams.wear_evidence.drive_wear_evidence` takes; without one the evidence uses
the type prior :data:`~tyrebayes.streams.cornering_stiffness.TYPE_PRIOR_CORNERING`.
"""

from __future__ import annotations

import numpy as np

from ...streams.cornering_stiffness import CorneringStiffness
from ..lateral.result import LateralFit
from ..result import Fit
from ..tyre.result import LATERAL_NODE, TyreFit


def cornering_stiffness_from_draws(
    c_y_front: np.ndarray, c_y_rear: np.ndarray, source: str = "lateral_fit"
) -> CorneringStiffness:
    """Medians of per-axle c_y draws [1/rad] and the larger of their log-sds.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> c = cornering_stiffness_from_draws(
    ...     20.0 * np.exp(0.1 * rng.standard_normal(4000)),
    ...     24.0 * np.exp(0.05 * rng.standard_normal(4000)),
    ... )
    >>> round(c.front_per_rad), round(c.rear_per_rad), round(c.log_sd, 2), c.source
    (20, 24, 0.1, 'lateral_fit')
    """
    draws = [np.asarray(c, dtype=float).ravel() for c in (c_y_front, c_y_rear)]
    for name, d in zip(("c_y_front", "c_y_rear"), draws, strict=True):
        if d.size < 2 or not np.all(np.isfinite(d) & (d > 0)):
            raise ValueError(f"{name}: expected at least 2 finite draws > 0, got {d.size} draws")
    log_sd = max(float(np.std(np.log(d))) for d in draws)
    return CorneringStiffness(
        float(np.median(draws[0])), float(np.median(draws[1])), log_sd, source
    )


def cornering_stiffness_from_lateral(lateral: LateralFit) -> CorneringStiffness:
    """The per-axle c_y of a lateral fit for the wear evidence (``source`` ``"lateral_fit"``).

    Parameters
    ----------
    lateral : LateralFit
        A lateral fit of the car (its posterior of ``c_y_front`` and ``c_y_rear`` [1/rad]).

    Returns
    -------
    CorneringStiffness
        Posterior medians and the larger of the two posterior log-sds.

    Examples
    --------
    >>> fit = fit_lateral(cornering_observations(frame, vehicle))  # doctest: +SKIP
    >>> cornering_stiffness_from_lateral(fit).source  # doctest: +SKIP
    'lateral_fit'
    """
    return cornering_stiffness_from_draws(
        lateral.draws("c_y_front"), lateral.draws("c_y_rear"), "lateral_fit"
    )


def cornering_stiffness_from_tyre_fit(fit: Fit) -> CorneringStiffness | None:
    """The per-axle c_y of a saved tyre fit's lateral part, or None where it has none to use.

    Parameters
    ----------
    fit : Fit
        A tyre fit (:func:`~tyrebayes.inference.result.load_fit` of ``fit-tyre --out``).

    Returns
    -------
    CorneringStiffness or None
        ``source`` ``"lateral_fit"``; None without a lateral posterior (no usable cornering) or
        with one not to be used (:meth:`.LateralFit.unusable_reason`).

    Examples
    --------
    >>> cornering_stiffness_from_tyre_fit(load_fit("tyre.nc"))  # doctest: +SKIP
    """
    if LATERAL_NODE not in fit.data.children:
        return None
    lateral = TyreFit.from_fit(fit).lateral
    if lateral is None or lateral.unusable_reason():
        return None
    return cornering_stiffness_from_lateral(lateral)
