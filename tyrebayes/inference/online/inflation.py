"""The slip errors' variance inflation, estimated as the residuals arrive.

Same estimator as the batch fit's (:func:`~tyrebayes.inference.tyre.window_correlation.
variance_inflation`: batch means over :data:`~tyrebayes.inference.tyre.window_correlation.
BLOCK_WINDOWS` consecutive slip windows, clipped to [1, MAX_INFLATION]), kept as running sums.
Until :data:`~tyrebayes.inference.tyre.window_correlation.MIN_BLOCKS` blocks are complete the batch
fit would use 1; the filter cannot revise the weight of windows it has already absorbed, so it
starts from a stated prior guess instead (:attr:`OnlineConfig.initial_inflation`) that the
estimate outweighs as blocks accrue.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from ..tyre.window_correlation import BLOCK_WINDOWS, MAX_INFLATION, MIN_BLOCKS
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
    sums: InflationSums,
    initial: float | Float[Array, ""],
    prior_blocks: float | Float[Array, ""],
) -> Float[Array, ""]:
    """The VIF the next step weighs its slips by: the prior guess and the estimate, pooled."""
    blocks = jnp.where(sums.n_blocks >= MIN_BLOCKS, sums.n_blocks, 0.0)
    return (prior_blocks * initial + blocks * estimated_inflation(sums)) / (prior_blocks + blocks)


def accrue_residuals(
    sums: InflationSums, z: Float[Array, "w"], used: Bool[Array, "w"]
) -> InflationSums:
    """Add one step's standardised slip residuals (in time order; ``used`` marks slip windows)."""
    k = BLOCK_WINDOWS
    weight = used.astype(z.dtype)
    z = jnp.where(used, z, 0.0)
    # Position of each used window counted from the start of the open batch-means block.
    position = sums.partial_count + jnp.cumsum(weight) - weight
    segment = jnp.floor(position / k).astype(jnp.int32)
    n_segments = z.shape[0] // k + 2  # static: blocks a step can touch
    segment_sums = jax.ops.segment_sum(z, segment, num_segments=n_segments)
    segment_sums = segment_sums.at[0].add(sums.partial_sum)
    count = sums.partial_count + jnp.sum(weight)
    n_closed = jnp.floor(count / k)
    closed = jnp.arange(n_segments) < n_closed
    return InflationSums(
        sum_z=sums.sum_z + jnp.sum(z),
        sum_z2=sums.sum_z2 + jnp.sum(z**2),
        n_z=sums.n_z + jnp.sum(weight),
        partial_sum=segment_sums[n_closed.astype(jnp.int32)],
        partial_count=count - k * n_closed,
        sum_block=sums.sum_block + jnp.sum(jnp.where(closed, segment_sums, 0.0)),
        sum_block2=sums.sum_block2 + jnp.sum(jnp.where(closed, segment_sums**2, 0.0)),
        n_blocks=sums.n_blocks + n_closed,
    )


__all__ = ["accrue_residuals", "empty_inflation", "estimated_inflation", "inflation_in_use"]
