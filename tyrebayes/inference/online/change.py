"""Abrupt change of C_xr (a tyre swap, a puncture, a new surface): a two-sided CUSUM of
predictive likelihood ratios.

Each step weighs the block's evidence for a C_xr shifted by ±δ with the filter's *predictive*
distribution, not its point estimate: the ratio of the block's predictive densities under
"θ ~ N(m + s, P)" and "θ ~ N(m, P)", s = ±δ e_C (log C_xr alone shifted), N(m, P) the predicted
Gaussian. By the Laplace approximation of both evidences at the update's mode θ* with covariance
Σ (exact for a Gaussian likelihood),

    g(s) = sᵀP⁻¹(θ* − m) − ½ sᵀ(P⁻¹ − P⁻¹ΣP⁻¹)s,

the innovation CUSUM of a Kalman filter (Basseville & Nikiforov 1993, *Detection of Abrupt
Changes*, §3.1.2 and eq. 2.2.9) in information form. It needs nothing the update does not
already give, and it is taken at the mode, where the block's likelihood is closest to
quadratic, not at the predicted mean: after a drive start the per-drive slip offset is back at
its prior there and the likelihood far from quadratic. With P → 0 it is the plug-in ratio
ℓ(m ± δe_C) − ℓ(m); with P wide against the block's information it goes to 0, because a block
cannot tell a shift from what the filter does not yet know. The plug-in ratio leaves that
uncertainty out: its increments are positive on average whenever m is off by more than δ/2
along a direction C_xr shares with the nuisances. The other coordinates keep their predictive
distribution under both hypotheses.

Page's recursion S± ← max(0, S± + g±) alarms when either exceeds h; with exact predictive
ratios the run length to a false alarm is at least e^h steps per side (Wald's inequality), which
sets h (:data:`~.config.CHANGE_THRESHOLD`).

One step's ratio counts at most h/(k − ½) per STEP_S of driving the step spans (at least one;
a step packed from sparse driving spans up to ``max_step_s``, :mod:`.windows`), so that an
alarm takes k STEP_S of driving (:attr:`~.config.OnlineConfig.change_min_steps`, 3: 90 s), and
more than one step while steps span less than (k − ½) STEP_S (PACKED_STEP_S, 60 s, does). A
change of C_xr persists, while a single block the model cannot explain (a transient it lacks:
a pothole, a feature error in a tight turn) moves the update far, and its ratio then speaks of
the misfit rather than of C_xr.
Capping an increment from above keeps exp(S) a supermartingale under the model, so the bound
stands (the cap is known before the step's ratio); a change whose blocks each carry more than
the cap is found after k STEP_S of driving instead of fewer.

The slips count with the filter's weight 1/VIF, so correlated slip errors do not read as
evidence. While the estimate itself is still moving (posterior sd of log C_xr above the gate)
the statistic stays at 0.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from .laplace_update import GaussianUpdate


def predictive_shift_ratios(
    predicted: tuple[Float[Array, "p"], Float[Array, "p p"]],
    updated: GaussianUpdate,
    *,
    index: int,
    shift: float | Float[Array, ""],
) -> Float[Array, "2"]:
    """The block's predictive log-likelihood ratios g₊, g₋ of θ_index shifted by ±``shift``.

    Parameters
    ----------
    predicted : (mean, cov)
        The predicted Gaussian N(m, P), before the block.
    updated : GaussianUpdate
        The Laplace update by the block: its mode θ* and covariance Σ.
    index : int
        The shifted coordinate (log C_xr).
    shift : float
        δ, in that coordinate's units.

    Examples
    --------
    A scalar θ ~ N(0, 1/4) and one y ~ N(θ, 1/4) at y = 0.3 (posterior N(0.15, 1/8)): the
    ratios are those of y ~ N(±δ, 1/4 + 1/4), the innovation test.

    >>> import jax.numpy as jnp
    >>> updated = GaussianUpdate(jnp.full(1, 0.15), jnp.full((1, 1), 0.125), jnp.zeros(()))
    >>> g = predictive_shift_ratios((jnp.zeros(1), jnp.full((1, 1), 0.25)), updated,
    ...                             index=0, shift=0.2)
    >>> [round(float(v), 6) for v in g]
    [0.08, -0.16]
    """
    (mean, cov), mode, post_cov = predicted, updated.mean, updated.cov
    direction = jnp.zeros_like(mean).at[index].set(1.0)
    pulled = jnp.linalg.solve(cov, direction)
    linear = pulled @ (mode - mean)
    quadratic = jnp.maximum(pulled @ direction - pulled @ post_cov @ pulled, 0.0)
    signs = jnp.asarray([1.0, -1.0], dtype=mean.dtype)
    ratios = signs * shift * linear - 0.5 * shift**2 * quadratic
    return jnp.where(jnp.isfinite(ratios), ratios, 0.0)


def cusum_step(
    ratios: Float[Array, "2"],
    cusum_up: Float[Array, ""],
    cusum_down: Float[Array, ""],
    *,
    armed: Bool[Array, ""],
    threshold: float | Float[Array, ""],
    max_increment: float | Float[Array, ""] = jnp.inf,
) -> tuple[Float[Array, ""], Float[Array, ""], Bool[Array, ""]]:
    """Page's two-sided recursion on one step's ratios, each capped at ``max_increment``
    (module docstring).

    Returns the new (S₊, S₋) and whether either crossed ``threshold``; both stay 0 while not
    ``armed``.
    """
    ratios = jnp.minimum(ratios, max_increment)
    up = jnp.where(armed, jnp.maximum(0.0, cusum_up + ratios[0]), 0.0)
    down = jnp.where(armed, jnp.maximum(0.0, cusum_down + ratios[1]), 0.0)
    return up, down, jnp.maximum(up, down) > threshold


__all__ = ["cusum_step", "predictive_shift_ratios"]
