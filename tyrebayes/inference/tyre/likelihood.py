"""The per-tyre model's per-window likelihood: what the parameters set in each window, the
Normal terms of its measured slip and force, and the block offsets integrated out.

Shared by :func:`~tyrebayes.inference.tyre.model.tyre_model`, the posterior predictive and the
online filter. Re-exported by :mod:`tyrebayes.inference.tyre.model`.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from ...physics.thermal import stiffness_with_sensitivity
from .curves import _slip_and_slope
from .data import TyreObservations


class WindowLikelihood(NamedTuple):
    """Per-window likelihood of :func:`tyre_model` given its parameters.

    ``slip_loc``, ``slip_scale``: Normal of the measured slip (slip windows); ``rho_loc``,
    ``rho_scale``: Normal of the measured force (all windows); ``below_peak``: the log of the
    probability that a slip window's true force lies under μ_max (0 for ABS and padding);
    ``block_offset``: each slip window's block offset given its block's residuals (its
    conditional mean; 0 elsewhere), which ``slip_loc`` leaves out; ``block_log_correction``: what
    integrating the block offsets out adds to the slip log-likelihood (a scalar).
    """

    slip_loc: jax.Array
    slip_scale: jax.Array
    rho_loc: jax.Array
    rho_scale: jax.Array
    below_peak: jax.Array
    block_offset: jax.Array
    block_log_correction: jax.Array


def block_offsets(
    residual: jax.Array, precision: jax.Array, block_index: jax.Array, drift_sd: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """Integrate out one Normal(0, τ²) slip offset per block from Normal slip residuals.

    With window precisions p_i (0 for windows that do not count) and residuals r_i, a block with
    P = Σ p_i and Q = Σ p_i r_i has marginal log-likelihood Σ log N(r_i; 0, 1/p_i)
    − ½ log(1 + τ²P) + ½ τ²Q²/(1 + τ²P) (Sherman-Morrison on the block's covariance
    diag(1/p) + τ²11ᵀ): exact, and O(n). Returns (the correction, summed over blocks; the
    conditional mean τ²Q/(1 + τ²P) of each window's block offset).
    """
    n = residual.shape[0]
    total_precision = jax.ops.segment_sum(precision, block_index, num_segments=n)
    total_weighted = jax.ops.segment_sum(precision * residual, block_index, num_segments=n)
    tau2 = drift_sd**2
    denominator = 1.0 + tau2 * total_precision
    correction = jnp.sum(-0.5 * jnp.log(denominator) + 0.5 * tau2 * total_weighted**2 / denominator)
    offset = (tau2 * total_weighted / denominator)[block_index]
    return correction, jnp.where(precision > 0, offset, 0.0)


def _per_window(site: jax.Array, index: jax.Array, n: int) -> jax.Array:
    """``site[index]``; with one drive or surface (``n``, static) a broadcast of its only value,
    whose derivatives XLA computes without the scatter-adds a gather's transpose takes."""
    if n == 1:
        return jnp.broadcast_to(jnp.reshape(site, (-1,))[0], index.shape)
    return site[index]


class WindowQuantities(NamedTuple):
    """What the parameters set in each window, before any observation is compared with them.

    The likelihood is a fixed function of these (:func:`likelihood_of_quantities`), so a
    curvature can be built from their first derivatives alone (the online filter's
    Gauss-Newton curvature, :mod:`tyrebayes.inference.online.block_likelihood`).

    ``slip_loc``, ``slip_scale``: Normal of the measured slip (slip windows, before the block
    offset); ``rho_loc``, ``rho_scale``: Normal of the measured force; ``headroom``: the true
    force's distance below μ_max in its sds (slip windows); ``drift_sd``: the block offsets' sd τ
    (a scalar; 0 without them).
    """

    slip_loc: jax.Array
    slip_scale: jax.Array
    rho_loc: jax.Array
    rho_scale: jax.Array
    headroom: jax.Array
    drift_sd: jax.Array


def window_quantities(params: dict, obs: TyreObservations, model: str) -> WindowQuantities:
    """The per-window quantities of :func:`window_likelihood` (``params`` as there)."""

    def per_drive(site):
        return _per_window(site, obs.drive_index, obs.n_drives)

    gain, level, spread = (
        per_drive(params[k]) for k in ("force_gain", "force_level", "force_spread")
    )
    rho_noise = params["rho_noise_scale"] * obs.rho_sd
    # The true force given its measurement, by Tweedie's formula on the density of the measured
    # forces (force_density.force_density_score): exact for Gaussian noise whatever the shape of
    # the force distribution. ρ_obs/g has noise η/g and score g·s(ρ_obs), so the gain just
    # divides. The variance factor is clipped to [0.05, 1]: with λ_ρ > 1 a single component's
    # factor 1 − λ²η²/(τ² + η²) can fall below zero. The upper bound dates from the kernel
    # estimate (raising it to 5 moved C_x by 0.3-0.5 points on one drive, then); between mixture
    # components the factor can exceed 1, and that is not re-measured.
    noise2 = rho_noise**2
    rho_hat = (obs.rho + noise2 * obs.rho_score) / gain
    rho_var = noise2 / gain**2 * jnp.clip(1.0 + noise2 * obs.rho_score_slope, 0.05, 1.0)
    c_x = stiffness_with_sensitivity(params["c_xr"], obs.temperature_c, params["temp_sensitivity"])
    if "load_sensitivity" in params:
        c_x = c_x * jnp.exp(params["load_sensitivity"] * obs.load_change)
    mu_window = _per_window(params["mu_max"], obs.surface_index, obs.n_surfaces)
    slip, slip_slope = _slip_and_slope(model, rho_hat, c_x, mu_window, params)
    slip_scale = jnp.sqrt((params["slip_noise_scale"] * obs.slip_sd) ** 2 + slip_slope**2 * rho_var)

    # ABS windows: the total force sits near the peak, the slip is not measurable.
    limit_mean = -gain * params["abs_force_ratio"] * mu_window
    # Window-to-window spread of ABS cycling around the shared ratio: ~2 % of μ.
    limit_scale = jnp.sqrt(noise2 + (0.02 * mu_window) ** 2)
    # Outside ABS the force is quasi-static and below the peak: the true force of every slip
    # window lies under μ. Without this the inverse, which maps forces beyond the peak to the
    # peak slip, would let a μ_max below the measured forces fit (a spurious mode: μ ~0.25 and
    # C_x twice the truth).
    headroom = (mu_window - jnp.abs(rho_hat)) / jnp.sqrt(rho_var + (0.02 * mu_window) ** 2)
    return WindowQuantities(
        slip_loc=slip + per_drive(params["slip_offset"]),
        slip_scale=slip_scale,
        rho_loc=jnp.where(obs.at_limit, limit_mean, gain * level),
        rho_scale=jnp.where(obs.at_limit, limit_scale, jnp.sqrt((gain * spread) ** 2 + noise2)),
        headroom=headroom,
        drift_sd=params.get("slip_drift_sd", jnp.zeros((), slip.dtype)),
    )


def likelihood_of_quantities(q: WindowQuantities, obs: TyreObservations) -> WindowLikelihood:
    """The windows' likelihood terms given their quantities (:func:`window_likelihood`)."""
    slip_window = obs.mask & ~obs.at_limit
    below_peak = jnp.where(slip_window, jax.scipy.special.log_ndtr(q.headroom), 0.0)
    precision = jnp.where(slip_window, obs.slip_weight / q.slip_scale**2, 0.0).astype(
        q.slip_loc.dtype
    )
    correction, offset = block_offsets(
        jnp.where(precision > 0, obs.slip - q.slip_loc, 0.0),
        precision,
        obs.block_index,
        q.drift_sd,
    )
    return WindowLikelihood(
        slip_loc=q.slip_loc,
        slip_scale=q.slip_scale,
        rho_loc=q.rho_loc,
        rho_scale=q.rho_scale,
        below_peak=below_peak,
        block_offset=offset,
        block_log_correction=correction,
    )


def window_likelihood(params: dict, obs: TyreObservations, model: str) -> WindowLikelihood:
    """The windows' likelihood terms of :func:`tyre_model` (see the module docstring).

    ``params`` holds the model's sampled sites by name (``c_xr``, ``temp_sensitivity``,
    ``mu_max``, ``abs_force_ratio``, ``rho_noise_scale``, ``slip_noise_scale``, ``slip_drift_sd``
    and ``load_sensitivity`` where the priors have them, the curve's shape sites of ``model`` and
    the per-drive ``slip_offset``, ``force_gain``, ``force_level``, ``force_spread``); other keys
    are ignored, so a posterior draw can be passed as it is. The model and the posterior
    predictive share it.
    """
    return likelihood_of_quantities(window_quantities(params, obs, model), obs)
