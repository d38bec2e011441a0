"""The log-likelihood of one block of windows given θ: the batch model's, term for term.

:func:`~tyrebayes.inference.tyre.model.window_likelihood` gives each window's Normal terms; this
sums them the way :func:`~tyrebayes.inference.tyre.model.tyre_model` does (slip windows weighted
by the slip weight, ABS windows' forces, the below-the-peak factors, the block's offset
integrated out). The slip windows' force marginal is left out: it is a function of the drive's
force level and spread only (no θ coordinate), so it is a constant here.

The log-likelihood is ℓ(θ) = F(q(θ)): θ sets each window's quantities q (slip and force means
and scales, the headroom below μ_max, the offsets' sd; :class:`~..tyre.model.WindowQuantities`)
and F compares them with the observations. Its Hessian is

    ∇²ℓ = Jᵀ ∇²F J + Σ_k ∂F/∂q_k ∇²q_k,     J = ∂q/∂θ.

:func:`block_curvature` keeps the first term (a generalised Gauss-Newton matrix; Schraudolph
2002, Martens 2020 §8): it needs only J, one forward pass per coordinate of θ, and F's Hessian in
q, which is cheap (logs, squares and per-block sums). The second term's weights ∂F/∂q_k are the
windows' standardised residuals and their squares less one, which have mean zero under the
model, so it grows as √n against the first term's n over a block of n windows, and near the
mode it is the least-squares residual curvature Gauss-Newton has always dropped. What it costs,
the Magic Formula's inverse curve differentiated twice (``benchmarks/online_curvature_cost.py``),
is most of an exact Hessian's.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jax.scipy.stats import norm
from jaxtyping import Array, Float

from ..tyre.data import TyreObservations
from ..tyre.model import (
    TyrePriors,
    WindowQuantities,
    likelihood_of_quantities,
    window_likelihood,
    window_quantities,
)
from .parameters import model_sites
from .windows import WindowBlocks


def _log_likelihood_of(q: WindowQuantities, block: WindowBlocks, obs: TyreObservations):
    """F(q): the block's log-likelihood given its windows' quantities."""
    lik = likelihood_of_quantities(q, obs)
    slip_window = block.mask & ~block.at_limit
    limit_window = block.mask & block.at_limit
    slip_term = jnp.where(
        slip_window, obs.slip_weight * norm.logpdf(block.slip, lik.slip_loc, lik.slip_scale), 0.0
    )
    limit_term = jnp.where(limit_window, norm.logpdf(block.rho, lik.rho_loc, lik.rho_scale), 0.0)
    return (
        jnp.sum(slip_term)
        + jnp.sum(limit_term)
        + jnp.sum(lik.below_peak)
        + lik.block_log_correction
    )


def block_log_likelihood(
    theta: Float[Array, "p"],
    block: WindowBlocks,
    slip_weight: Float[Array, ""],
    model: str,
    priors: TyrePriors,
) -> Float[Array, ""]:
    """log p(block | θ) [nats] (0 for a block of padding only)."""
    obs = block.observations(slip_weight)
    q = window_quantities(model_sites(theta, model, priors), obs, model)
    return _log_likelihood_of(q, block, obs)


def block_curvature(
    theta: Float[Array, "p"],
    block: WindowBlocks,
    slip_weight: Float[Array, ""],
    model: str,
    priors: TyrePriors,
) -> tuple[Float[Array, ""], Float[Array, "p"], Float[Array, "p p"]]:
    """ℓ(θ), ∇ℓ(θ) and the Gauss-Newton information −Jᵀ∇²F J of the block (module docstring).

    The value and gradient are exact (∇ℓ = Jᵀ∇F); the information drops the curvature of the
    quantities themselves. It is symmetric but not always positive: F is not concave in the
    scales where residuals exceed them, as far from the mode.
    """
    obs = block.observations(slip_weight)

    def quantities(t):
        return window_quantities(model_sites(t, model, priors), obs, model)

    def log_likelihood_of(q):
        return _log_likelihood_of(q, block, obs)

    basis = jnp.eye(theta.shape[0], dtype=theta.dtype)
    q, tangents = jax.vmap(lambda e: jax.jvp(quantities, (theta,), (e,)), out_axes=(None, 0))(basis)
    value, gradient_q = jax.value_and_grad(log_likelihood_of)(q)
    curved = jax.vmap(lambda t: jax.jvp(jax.grad(log_likelihood_of), (q,), (t,))[1])(tangents)

    def rows(tree):
        return jnp.concatenate(
            [jnp.reshape(leaf, (theta.shape[0], -1)) for leaf in jax.tree.leaves(tree)], axis=1
        )

    jacobian = rows(tangents)
    gradient = jacobian @ jnp.concatenate([jnp.ravel(x) for x in jax.tree.leaves(gradient_q)])
    information = -jacobian @ rows(curved).T
    return value, gradient, 0.5 * (information + information.T)


def standardised_slip_residuals(
    theta: Float[Array, "p"], block: WindowBlocks, model: str, priors: TyrePriors
) -> Float[Array, "w"]:
    """(σ_obs − loc − block offset)/scale of each slip window at θ (0 elsewhere).

    What the batch fit's slip weights read (:func:`~tyrebayes.inference.tyre.fit`).
    """
    obs = block.observations(jnp.ones((), dtype=block.slip.dtype))
    lik = window_likelihood(model_sites(theta, model, priors), obs, model)
    z = (block.slip - lik.slip_loc - lik.block_offset) / lik.slip_scale
    return jnp.where(block.mask & ~block.at_limit, z, 0.0)


__all__ = ["block_curvature", "block_log_likelihood", "standardised_slip_residuals"]
