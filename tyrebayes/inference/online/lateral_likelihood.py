"""A block's likelihood in the online lateral estimator: the batch model's, with its Fisher
information.

The block's likelihood is the batch lateral model's own
(:func:`~tyrebayes.inference.lateral.model.log_likelihoods` and its peak bound) on the block's
samples, braking samples left out (:mod:`.lateral_blocks`), in three parts: the steering
equation, the kinematic equation and the peak bound (:func:`block_parts`). The estimator weights
the two equations by 1/VIF (:func:`block_information`, :mod:`.lateral_vif`) and takes their
Fisher information as the Laplace update's curvature (:mod:`.lateral`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..lateral.data import CorneringObservations
from ..lateral.model import LateralPriors, axle_state, residuals
from .lateral_prior import constrained


def _terms(theta, obs: CorneringObservations, names: tuple[str, ...], priors: LateralPriors):
    """Per sample: the steering residual and the log of its sd, the kinematic residual and the
    log of its sd, and the excess of an axle's force over μ_y in units of the peak margin."""
    p = constrained(theta, names)
    state = axle_state(obs, p)
    steer, kinematic = residuals(obs, p)
    log_steer_sd = 0.5 * jnp.log(
        p["steer_noise"] ** 2 + p["force_noise"] ** 2 * (state.slope_front**2 + state.slope_rear**2)
    )
    log_kin_sd = jnp.broadcast_to(jnp.log(p["kinematic_noise"]), kinematic.shape)
    peak = jnp.maximum(jnp.abs(state.rho_front), jnp.abs(state.rho_rear))
    beyond = jnp.maximum(peak - p["mu_y"], 0.0) / priors.peak_margin
    return steer, log_steer_sd, kinematic, log_kin_sd, beyond


def block_parts(
    theta: Float[Array, " p"],
    obs: CorneringObservations,
    names: tuple[str, ...],
    priors: LateralPriors,
) -> tuple[Float[Array, "3"], Float[Array, "3 p"], Float[Array, "3 p p"]]:
    """The block's log-likelihood at ``theta`` in three parts (steering equation, kinematic
    equation, peak bound; unweighted): each part's value, gradient and Fisher information.

    The likelihood is the batch model's (:func:`~tyrebayes.inference.lateral.model.lateral_model`):
    each equation's Normal terms on its mask and the peak bound (an axle cannot give more than
    μ_y); the priors are the filter's Gaussian, not here. For a Normal term with residual e and
    sd σ the Fisher information is ∇e∇eᵀ/σ² + 2∇log σ∇log σᵀ, for the peak bound its
    Gauss-Newton matrix: all from one forward-mode Jacobian of the per-sample terms, about a
    third of the exact Hessian's cost (which also bends the wrong way far from the mode), and
    gradient and value from the same pass.
    """

    def terms(t):
        return _terms(t, obs, names, priors)

    values, jacobians = jax.vmap(lambda e: jax.jvp(terms, (theta,), (e,)), out_axes=(None, 1))(
        jnp.eye(theta.shape[0], dtype=theta.dtype)
    )
    steer, log_steer_sd, kin, log_kin_sd, beyond = values
    j_steer, j_steer_sd, j_kin, j_kin_sd, j_beyond = jacobians
    ms = obs.mask.astype(theta.dtype)
    mk = obs.mask_kinematic.astype(theta.dtype)
    zs = jnp.where(obs.mask, steer * jnp.exp(-log_steer_sd), 0.0)
    zk = jnp.where(obs.mask_kinematic, kin * jnp.exp(-log_kin_sd), 0.0)
    bb = jnp.where(obs.mask, beyond, 0.0)
    inv_s = jnp.where(obs.mask, jnp.exp(-log_steer_sd), 0.0)
    inv_k = jnp.where(obs.mask_kinematic, jnp.exp(-log_kin_sd), 0.0)
    value = jnp.stack(
        [
            jnp.sum(ms * (-0.5 * zs**2 - log_steer_sd)),
            jnp.sum(mk * (-0.5 * zk**2 - log_kin_sd)),
            -0.5 * jnp.sum(bb**2),
        ]
    )
    # ∂/∂θ of −½ z² − log σ with z = e/σ: −z/σ ∇e + (z² − 1) ∇log σ.
    gradient = jnp.stack(
        [
            (-zs * inv_s) @ j_steer + (ms * (zs**2 - 1.0)) @ j_steer_sd,
            (-zk * inv_k) @ j_kin + (mk * (zk**2 - 1.0)) @ j_kin_sd,
            -bb @ j_beyond,
        ]
    )
    scaled_s = j_steer * inv_s[:, None]
    scaled_k = j_kin * inv_k[:, None]
    sd_s = j_steer_sd * jnp.sqrt(2.0 * ms)[:, None]
    sd_k = j_kin_sd * jnp.sqrt(2.0 * mk)[:, None]
    peak = jnp.where(obs.mask[:, None], j_beyond, 0.0)
    information = jnp.stack(
        [
            scaled_s.T @ scaled_s + sd_s.T @ sd_s,
            scaled_k.T @ scaled_k + sd_k.T @ sd_k,
            peak.T @ peak,
        ]
    )
    return value, gradient, information


def block_information(
    theta: Float[Array, " p"],
    obs: CorneringObservations,
    weights: Float[Array, "2"],
    names: tuple[str, ...],
    priors: LateralPriors,
) -> tuple[Float[Array, ""], Float[Array, " p"], Float[Array, "p p"]]:
    """The block's log-likelihood at ``theta`` with the equations weighted 1/VIF, its gradient
    and its Fisher information (:func:`block_parts`, the peak bound unweighted)."""
    value, gradient, information = block_parts(theta, obs, names, priors)
    w = jnp.concatenate([weights, jnp.ones(1, weights.dtype)])
    return w @ value, w @ gradient, jnp.einsum("k,kij->ij", w, information)


def block_log_likelihood(
    theta: Float[Array, " p"],
    obs: CorneringObservations,
    weights: Float[Array, "2"],
    names: tuple[str, ...],
    priors: LateralPriors,
) -> Float[Array, ""]:
    """The block's log-likelihood at ``theta`` alone (:func:`block_information`'s value)."""
    steer, log_steer_sd, kin, log_kin_sd, beyond = _terms(theta, obs, names, priors)
    zs = steer * jnp.exp(-log_steer_sd)
    zk = kin * jnp.exp(-log_kin_sd)
    return (
        weights[0] * jnp.sum(jnp.where(obs.mask, -0.5 * zs**2 - log_steer_sd, 0.0))
        + weights[1] * jnp.sum(jnp.where(obs.mask_kinematic, -0.5 * zk**2 - log_kin_sd, 0.0))
        - 0.5 * jnp.sum(jnp.where(obs.mask, beyond**2, 0.0))
    )


__all__ = ["block_information", "block_log_likelihood", "block_parts"]
