"""The slip errors' variance inflation, estimated as the residuals arrive.

Same estimator as the batch fit's (:func:`~tyrebayes.inference.window_correlation.
variance_inflation`: batch means over :data:`~tyrebayes.inference.window_correlation.
BLOCK_WINDOWS` consecutive slip windows, clipped to [1, MAX_INFLATION]), kept as running sums.
Until :data:`~tyrebayes.inference.window_correlation.MIN_BLOCKS` blocks are complete the batch
fit would use 1; the filter cannot revise the weight of windows it has already absorbed, so it
starts from a stated prior guess instead (:attr:`OnlineConfig.initial_inflation`) that the
estimate outweighs as blocks accrue.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from ..window_correlation import BLOCK_WINDOWS, MAX_INFLATION, MIN_BLOCKS
from .state import InflationSums


def empty_inflation(dtype=float) -> InflationSums:
    zero = jnp.zeros((), dtype=dtype)
    return InflationSums(zero, zero, zero, zero, zero, zero, zero, zero)


def estimated_inflation(sums: InflationSums) -> Float[Array, ""]:
    """The batch-means VIF of the residuals so far (1 before MIN_BLOCKS blocks)."""
    n = jnp.maximum(sums.n_z, 1.0)
    z_mean = sums.sum_z / n
    variance = sums.sum_z2 / n - z_mean**2
    k = float(BLOCK_WINDOWS)
    blocks = jnp.maximum(sums.n_blocks, 1.0)
    # Σ_b (S_b − k z̄)² / n_b, the block sums centred on the overall mean as the batch does.
    centred = (sums.sum_block2 - 2.0 * k * z_mean * sums.sum_block) / blocks + (k * z_mean) ** 2
    vif = jnp.clip(centred / (k * jnp.maximum(variance, 1e-300)), 1.0, MAX_INFLATION)
    usable = (sums.n_blocks >= MIN_BLOCKS) & (variance > 0)
    return jnp.where(usable, vif, 1.0)


def inflation_in_use(
    sums: InflationSums, initial: float, prior_blocks: float
) -> Float[Array, ""]:
    """The VIF the next step weighs its slips by: the prior guess and the estimate, pooled."""
    blocks = jnp.where(sums.n_blocks >= MIN_BLOCKS, sums.n_blocks, 0.0)
    return (prior_blocks * initial + blocks * estimated_inflation(sums)) / (prior_blocks + blocks)


def accrue_residuals(
    sums: InflationSums, z: Float[Array, "w"], used: Bool[Array, "w"]
) -> InflationSums:
    """Add one step's standardised slip residuals (in time order; ``used`` marks slip windows).

    A step holds fewer windows than a batch-means block, so it completes at most one block.
    """
    if z.shape[0] >= BLOCK_WINDOWS:
        raise ValueError(
            f"inflation: expected fewer than {BLOCK_WINDOWS} windows per step, got {z.shape[0]}"
        )
    weight = used.astype(z.dtype)
    z = jnp.where(used, z, 0.0)
    position = sums.partial_count + jnp.cumsum(weight) - weight  # 0-based within the open block
    first = position < BLOCK_WINDOWS
    sum_first = jnp.sum(jnp.where(first, z, 0.0))
    sum_next = jnp.sum(jnp.where(first, 0.0, z))
    count = sums.partial_count + jnp.sum(weight)
    closes = count >= BLOCK_WINDOWS
    closed = sums.partial_sum + sum_first
    return InflationSums(
        sum_z=sums.sum_z + jnp.sum(z),
        sum_z2=sums.sum_z2 + jnp.sum(z**2),
        n_z=sums.n_z + jnp.sum(weight),
        partial_sum=jnp.where(closes, sum_next, closed),
        partial_count=jnp.where(closes, count - BLOCK_WINDOWS, count),
        sum_block=sums.sum_block + jnp.where(closes, closed, 0.0),
        sum_block2=sums.sum_block2 + jnp.where(closes, closed**2, 0.0),
        n_blocks=sums.n_blocks + closes.astype(z.dtype),
    )


__all__ = ["accrue_residuals", "empty_inflation", "estimated_inflation", "inflation_in_use"]
