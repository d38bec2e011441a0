"""V_max inputs from a lateral posterior: the measured per-axle c_y and μ_y, and μ_y's source.

The per-axle c_y front and rear [1/rad over the static axle load] enter the simulation as they
are (:class:`~tyrebayes.physics.lanechange.AxleTyres`; C_f = c_y_front · m g l_r / L N/rad); μ_y
is the lateral fit's where the drive neared the peak, else the longitudinal μ_max where that fit
observed it, else the lateral posterior's (the surface's prior, bounded below by the forces the
drive used). A measured μ_y belongs to the drive's surface.
"""

from __future__ import annotations

import json

import jax
import numpy as np
from jaxtyping import Array

from ..lateral.result import LateralFit
from .inputs import VmaxInputs


def _resample(key: Array, n_have: int, n: int) -> np.ndarray:
    """Indices of n draws out of n_have: without replacement where there are enough."""
    if n_have < 1:
        raise ValueError("expected at least one posterior draw, got none")
    if n <= n_have:
        return np.asarray(jax.random.permutation(key, n_have)[:n])
    return np.asarray(jax.random.randint(key, (n,), 0, n_have))


def lateral_vmax_inputs(
    key: Array,
    lateral: LateralFit,
    n: int,
    *,
    mu_max: np.ndarray | None = None,
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
        Draws of μ_max from a longitudinal fit that observed its peak on this surface: used
        where the lateral fit did not observe μ_y (``mu_y_source`` ``"mu_max"``). Without it,
        an unobserved μ_y is the lateral posterior's own, the surface's prior bounded below by
        the forces the drive used (``"surface_prior"``).
    surface : str, optional
        The surface μ_y belongs to (default: the lateral fit's).

    Returns
    -------
    VmaxInputs
        ``lateral_source`` ``"measured"``; ``mu_y_source`` ``"measured"`` where
        ``lateral.mu_y_observed``, else as above, with a note saying so.

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
    k_draw, k_mu = jax.random.split(key)
    idx = _resample(k_draw, c_f.shape[0], n)
    c_f, c_r, mu = c_f[idx], c_r[idx], mu[idx]
    if lateral.mu_y_observed:
        mu_source, note = "measured", ""
    elif mu_max is not None:
        mu_max = np.asarray(mu_max, float).ravel()
        mu = mu_max[_resample(k_mu, mu_max.size, n)]
        mu_source = "mu_max"
        note = "mu_y not observed (the drive did not near the lateral peak): mu_max used"
    else:
        mu_source = "surface_prior"
        note = (
            "mu_y not observed and no observed mu_max: the lateral posterior's mu_y, the "
            f"{surface} prior bounded below by the forces the drive used"
        )
    return VmaxInputs(c_f, c_r, mu, "measured", mu_source, surface, note)
