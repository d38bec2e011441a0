"""The log-likelihood of one block of windows given θ: the batch model's, term for term.

:func:`~tyrebayes.inference.tyre.model.window_likelihood` gives each window's Normal terms; this
sums them the way :func:`~tyrebayes.inference.tyre.model.tyre_model` does (slip windows weighted
by the slip weight, ABS windows' forces, the below-the-peak factors, the block's offset
integrated out). The slip windows' force marginal is left out: it is a function of the drive's
force level and spread only (no θ coordinate), so it is a constant here.
"""

from __future__ import annotations

import jax.numpy as jnp
from jax.scipy.stats import norm
from jaxtyping import Array, Float

from ..tyre.model import TyrePriors, window_likelihood
from .parameters import model_sites
from .windows import WindowBlocks


def block_log_likelihood(
    theta: Float[Array, "p"],
    block: WindowBlocks,
    slip_weight: Float[Array, ""],
    kind: str,
    priors: TyrePriors,
) -> Float[Array, ""]:
    """log p(block | θ) [nats] (0 for a block of padding only)."""
    obs = block.observations(slip_weight)
    lik = window_likelihood(model_sites(theta, kind, priors), obs, kind)
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


def standardised_slip_residuals(
    theta: Float[Array, "p"], block: WindowBlocks, kind: str, priors: TyrePriors
) -> Float[Array, "w"]:
    """(σ_obs − loc − block offset)/scale of each slip window at θ (0 elsewhere).

    What the batch fit's slip weights read (:func:`~tyrebayes.inference.tyre.fit`).
    """
    obs = block.observations(jnp.ones((), dtype=block.slip.dtype))
    lik = window_likelihood(model_sites(theta, kind, priors), obs, kind)
    z = (block.slip - lik.slip_loc - lik.block_offset) / lik.slip_scale
    return jnp.where(block.mask & ~block.at_limit, z, 0.0)


__all__ = ["block_log_likelihood", "standardised_slip_residuals"]
