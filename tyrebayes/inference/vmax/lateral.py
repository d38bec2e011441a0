"""V_max inputs from a lateral posterior: the measured per-axle c_y and μ_y, and μ_y's source.

The per-axle c_y front and rear [1/rad over the static axle load] enter the simulation as they
are (:class:`~tyrebayes.physics.lanechange.AxleTyres`; C_f = c_y_front · m g l_r / L N/rad); μ_y
is the lateral fit's where the drive neared the peak, else the longitudinal μ_max (observed, or
the tyre fit's prior on that surface), else a prior: the tyre type's μ_y = 0.95 μ_type on dry
asphalt where the type is known, the surface's otherwise. An unobserved μ_y is never the
lateral posterior's own: short of the peak, what moves it is the curve's shape, which load
transfer and a load-dependent stiffness bend as much as μ_y does. Every fallback is bounded
below by the forces the drive used. A measured μ_y belongs to the drive's surface.
"""

from __future__ import annotations

import json

import jax
import numpy as np
from jaxtyping import Array

from ..lateral.model import LateralPriors
from ..lateral.result import LateralFit
from .inputs import VmaxInputs
from .type_relations import lateral_draws


def _resample(key: Array, n_have: int, n: int) -> np.ndarray:
    """Indices of n draws out of n_have: without replacement where there are enough."""
    if n_have < 1:
        raise ValueError("expected at least one posterior draw, got none")
    if n <= n_have:
        return np.asarray(jax.random.permutation(key, n_have)[:n])
    return np.asarray(jax.random.randint(key, (n,), 0, n_have))


def _at_least(key: Array, draws: np.ndarray, bound: float, n: int) -> np.ndarray:
    """n draws of ``draws`` conditioned on being at least ``bound`` (the bound itself if none
    is)."""
    kept = draws[draws >= bound]
    if kept.size == 0:
        return np.full(n, bound)
    return kept[_resample(key, kept.size, n)]


def surface_mu_y_draws(key: Array, surface: str, n: int) -> np.ndarray:
    """n draws of μ_y's prior on ``surface`` (the lateral model's, the longitudinal μ_max's)."""
    median, log_sd = LateralPriors().mu_y_prior(surface)
    return median * np.exp(log_sd * np.asarray(jax.random.normal(key, (n,))))


def _prior_mu_y(key: Array, surface: str, tyre_type: str | None, n: int) -> tuple[np.ndarray, str]:
    """Draws of μ_y's prior and its source: the type relation on dry asphalt, else the
    surface's."""
    if tyre_type is not None and surface == "dry":
        return np.asarray(lateral_draws(key, 1.0, tyre_type, n)[1]), "type_prior"
    return surface_mu_y_draws(key, surface, n), "surface_prior"


def lateral_vmax_inputs(
    key: Array,
    lateral: LateralFit,
    n: int,
    *,
    mu_max: np.ndarray | None = None,
    mu_max_observed: bool = True,
    tyre_type: str | None = None,
    surface: str | None = None,
) -> VmaxInputs:
    """Draws of the measured per-axle c_y and of μ_y from a lateral posterior.

    c_y front, rear and μ_y are taken at the same posterior draws, which keeps their
    correlation (a steady drive measures the gradient well and the split poorly).

    Parameters
    ----------
    key : jax.Array
        PRNG key.
    lateral : LateralFit
        The lateral fit (:func:`~tyrebayes.inference.lateral.fit_lateral`).
    n : int
        Number of draws (without replacement where the posterior has as many).
    mu_max : array_like, optional
        Draws of μ_max from a longitudinal fit on this surface: used where the lateral fit did
        not observe μ_y (``mu_y_source`` ``"mu_max"``).
    mu_max_observed : bool
        Whether that fit observed μ_max's peak (else its draws are its prior's, said so in the
        note).
    tyre_type : str, optional
        Without ``mu_max``: the tyre type whose relation μ_y = 0.95 μ_type gives μ_y on dry
        asphalt (``"type_prior"``); without it, or on another surface, the surface's prior
        (``"surface_prior"``).
    surface : str, optional
        The surface μ_y belongs to (default: the lateral fit's).

    Returns
    -------
    VmaxInputs
        ``lateral_source`` ``"measured"``; ``mu_y_source`` ``"measured"`` where
        ``lateral.mu_y_observed``, else as above, with a note saying so. A fallback's draws
        are conditioned on μ_y at least the forces the drive used (the 99th percentile of the
        axles' |ρ_y|, :attr:`LateralFit.peak_use`).

    Examples
    --------
    >>> x = lateral_vmax_inputs(key, fit_lateral(obs), 400)  # doctest: +SKIP
    >>> x.lateral_source, x.mu_y_source  # doctest: +SKIP
    ('measured', 'surface_prior')
    """
    if surface is None:
        surface = str(json.loads(lateral.fit.provenance.settings).get("surface", "unknown"))
    c_f, c_r = lateral.draws("c_y_front"), lateral.draws("c_y_rear")
    mu = lateral.draws("mu_y")
    used = float(lateral.peak_use) * float(np.mean(mu))
    k_draw, k_mu, k_bound = jax.random.split(key, 3)
    idx = _resample(k_draw, c_f.shape[0], n)
    c_f, c_r, mu = c_f[idx], c_r[idx], mu[idx]
    bounded = f"at least the forces the drive used ({used:.2f})"
    if lateral.mu_y_observed:
        mu_source, note = "measured", ""
    elif mu_max is not None:
        mu = _at_least(k_bound, np.asarray(mu_max, float).ravel(), used, n)
        mu_source = "mu_max"
        note = "mu_y not observed (the drive did not near the lateral peak): mu_max used"
        if not mu_max_observed:
            note += f" (not observed either: the tyre fit's prior on {surface})"
        note += f", {bounded}"
    else:
        prior, mu_source = _prior_mu_y(k_mu, surface, tyre_type, 4 * n)
        mu = _at_least(k_bound, prior, used, n)
        what = (
            f"the {tyre_type} type's 0.95 mu_type on dry asphalt"
            if mu_source == "type_prior"
            else f"the {surface} prior"
        )
        note = f"mu_y not observed and no mu_max: {what}, {bounded}"
    return VmaxInputs(c_f, c_r, mu, "measured", mu_source, surface, note)
