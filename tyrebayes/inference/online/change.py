"""Abrupt change of C_xr (a tyre swap, a puncture, a new surface): a two-sided CUSUM.

Each step, before the block updates the estimate, the block's log-likelihood ratio of a C_xr
shifted by ±δ against the predicted mean,

    g± = ℓ(m + ±δ e_C) − ℓ(m),

is the exact increment of Page's CUSUM for that alternative (Page 1954; Basseville & Nikiforov
1993, *Detection of Abrupt Changes*, eq. 2.2.9), S± ← max(0, S± + g±), alarm when either exceeds
h. Its run length to a false alarm is at least e^h steps per side when the likelihood is right
(Wald's inequality), which sets h (:data:`~.config.CHANGE_THRESHOLD`). The other coordinates stay
at their predicted mean: a slip-offset change is what each block's own offset absorbs, and a
slope change is what a tyre swap makes. The increments count the slips with the filter's weight
1/VIF, so correlated slip errors do not read as evidence.

While the estimate itself is still moving (posterior sd of log C_xr above the gate) the
statistic stays at 0: the estimator is learning, not witnessing a change.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float


def cusum_step(
    log_likelihood: Callable[[Float[Array, "p"]], Float[Array, ""]],
    mean: Float[Array, "p"],
    cov: Float[Array, "p p"],
    cusum_up: Float[Array, ""],
    cusum_down: Float[Array, ""],
    *,
    index: int,
    shift: float,
    threshold: float,
    gate_sd: float,
) -> tuple[Float[Array, ""], Float[Array, ""], Bool[Array, ""]]:
    """One CUSUM step on coordinate ``index`` of θ (module docstring).

    Returns the new (S₊, S₋) and whether either crossed ``threshold``.
    """
    direction = jnp.zeros_like(mean).at[index].set(shift)
    points = jnp.stack([mean, mean + direction, mean - direction])
    values = jax.vmap(log_likelihood)(points)
    increments = values[1:] - values[0]
    increments = jnp.where(jnp.isfinite(increments), increments, 0.0)
    armed = jnp.sqrt(cov[index, index]) <= gate_sd
    up = jnp.where(armed, jnp.maximum(0.0, cusum_up + increments[0]), 0.0)
    down = jnp.where(armed, jnp.maximum(0.0, cusum_down + increments[1]), 0.0)
    return up, down, jnp.maximum(up, down) > threshold


__all__ = ["cusum_step"]
