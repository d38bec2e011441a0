"""The usual in-car estimator, for comparison: an extended Kalman filter on the linear slip model.

State x = (C_x, s₀), slope and slip offset; each slip window observes its force through
ρ_obs = C_x (σ_obs − s₀) + v with Var v = sρ² + C_x² sσ² (the slip noise carried through the
slope, to first order), one scalar EKF update per window (Gustafsson et al. 2001 and the
vehicle-parameter learners in production driver assistance do much the same). It has what the
online estimator leaves out: no curve shape (C_x is the secant), no force gain, no block
offsets, no correlation of the slip errors, and force regressed on noisy slip (attenuation).
The random walk is the online estimator's (:data:`~.config.DRIFT_PER_SQRT_S`, C_x relative).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..tyre.model import TyrePriors
from .config import DRIFT_PER_SQRT_S
from .windows import WindowBlocks


class LinearEkfTrajectory(eqx.Module):
    """Per step: the EKF's C_x mean and sd [-] and the step's time [s]."""

    time_s: Float[Array, "t"]
    c_x_mean: Float[Array, "t"]
    c_x_sd: Float[Array, "t"]


def linear_ekf(blocks: WindowBlocks, priors: TyrePriors | None = None) -> LinearEkfTrajectory:
    """Run the linear-slip EKF over a stream's steps (module docstring), from the type prior."""
    return _linear_ekf(blocks, TyrePriors() if priors is None else priors)


@eqx.filter_jit
def _linear_ekf(blocks: WindowBlocks, priors: TyrePriors) -> LinearEkfTrajectory:
    c0 = priors.c_xr_median
    mean0 = jnp.asarray([c0, 0.0])
    cov0 = jnp.diag(jnp.asarray([(priors.c_xr_log_sd * c0) ** 2, priors.slip_offset_sd**2]))
    c_drift = DRIFT_PER_SQRT_S["log_c_xr"]
    s_drift = DRIFT_PER_SQRT_S["slip_offset"]

    def window(carry, w):
        mean, cov = carry
        slip, rho, slip_sd, rho_sd, use = w
        c, s0 = mean[0], mean[1]
        predicted = c * (slip - s0)
        h = jnp.stack([slip - s0, -c])
        r = rho_sd**2 + c**2 * slip_sd**2
        innovation_var = h @ cov @ h + r
        gain = cov @ h / innovation_var
        new_mean = mean + gain * (rho - predicted)
        new_cov = cov - jnp.outer(gain, h @ cov)
        new_cov = 0.5 * (new_cov + new_cov.T)
        return (jnp.where(use, new_mean, mean), jnp.where(use, new_cov, cov)), None

    def step(carry, block):
        mean, cov, time = carry
        elapsed = jnp.maximum(block.time_s - time, 0.0)
        q = jnp.stack([(c_drift * mean[0]) ** 2, s_drift**2]) * elapsed
        cov = cov + jnp.diag(q)
        use = block.mask & ~block.at_limit
        (mean, cov), _ = jax.lax.scan(
            window, (mean, cov), (block.slip, block.rho, block.slip_sd, block.rho_sd, use)
        )
        time = jnp.maximum(block.time_s, time)
        return (mean, cov, time), (time, mean[0], jnp.sqrt(cov[0, 0]))

    _, (time, c_mean, c_sd) = jax.lax.scan(
        step, (mean0, cov0, jnp.zeros((), dtype=mean0.dtype)), blocks
    )
    return LinearEkfTrajectory(time_s=time, c_x_mean=c_mean, c_x_sd=c_sd)


__all__ = ["LinearEkfTrajectory", "linear_ekf"]
