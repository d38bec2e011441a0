"""A tyre swap at a drive start: the Bayes factor of a new tyre against the one carried over.

A tyre is swapped with the car standing, so a swap happens, if at all, at a drive start. From
each drive start a second filter, the *challenger*, runs beside the estimate: the same blocks,
the same per-drive and sensor coordinates, but the tyre's own coordinates (C_xr, κ, μ_max, the
ABS force ratio, the curve's shape; :data:`TYRE_COORDINATES`) started again from the type prior,
as a new tyre would be. Each filter's Laplace update gives the block's predictive log-density
(:attr:`~.laplace_update.GaussianUpdate.log_evidence`), and their running difference since the
drive start is the log Bayes factor of "a new tyre since this drive start" against "the same
tyre" (Kass & Raftery 1995, with the predictive-sequential form of Dawid 1984).

Why a second test beside the mid-drive CUSUM of :mod:`.change`: a swapped tyre differs in its
whole curve, and the carried-over filter explains part of a new tyre's slips by moving its
weakly known shape and the new drive's force gain, so evidence for a step of C_xr alone drains
away within a few blocks of the swap. The challenger asks the question a swap poses: are this
drive's slips better told by a tyre learned from them alone?

Stated false-alarm rate: under "same tyre", the Bayes factor is a non-negative martingale with
mean 1 (the challenger's predictive is a proper mixture over tyres), so by Ville's inequality it
ever exceeds e^h within a drive with probability at most e^{-h}. With h =
:data:`~.config.SWAP_THRESHOLD` that is at most 1/800 per drive start: ≤ 0.5 false alarms per
100 hours of drives of 15 minutes and longer, half the issue's budget (the other half is the
mid-drive CUSUM's). The bound holds to the extent that the filters' Laplace evidences are the
model's; ``benchmarks/online_change.py`` counts the alarms on drives without a change. The
challenger runs for :attr:`~.config.OnlineConfig.swap_window_steps` steps after a drive start:
a swap the data cannot show by then is not one the estimate needs to restart for.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from .laplace_update import GaussianUpdate


def swap_step(
    challenger: GaussianUpdate,
    carried: GaussianUpdate,
    log_bayes_factor: Float[Array, ""],
    *,
    drive_start: Bool[Array, ""],
    active: Bool[Array, ""],
    threshold: float | Float[Array, ""],
) -> tuple[Float[Array, ""], Bool[Array, ""]]:
    """The log Bayes factor of a swap at the last drive start after this block, and whether it
    crossed ``threshold`` (module docstring); it stays where it was while not ``active``."""
    increment = jnp.where(active, challenger.log_evidence - carried.log_evidence, 0.0)
    increment = jnp.where(jnp.isfinite(increment), increment, 0.0)
    log_bayes_factor = jnp.where(drive_start, 0.0, log_bayes_factor) + increment
    return log_bayes_factor, active & (log_bayes_factor > threshold)


def either(flag: Bool[Array, ""], first, second):
    """``first`` where ``flag`` else ``second``, leaf by leaf (pytrees of one structure)."""
    return jax.tree.map(lambda a, b: jnp.where(flag, a, b), first, second)


__all__ = ["either", "swap_step"]
