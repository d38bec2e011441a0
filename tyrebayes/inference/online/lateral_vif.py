"""The variance inflation of the online lateral estimator's two equations, as the data arrive.

The batch fit weights each equation by 1/VIF of its residuals
(:func:`~tyrebayes.inference.lateral.inflation.residual_inflation`). Online, each equation's VIF is
estimated as the residuals at each block's mode arrive, by the batch's rule: the largest of the
AR(1) factor and the batch-means factors at 10, 30 and 60 s (each once :data:`MIN_CHUNKS`
batches are in; batches on the clock, those at least half valid), blended with
:data:`INITIAL_VIF` over the first minute and a half (:class:`ResidualMoments`). On real roads
the slow batches dominate (road bank, a curve that misfits over a corner) and need minutes of
data to show; until both equations have seen :data:`MIN_CHUNKS` batches of 30 s
(:meth:`ResidualMoments.settled`) nothing is reported.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

#: VIF assumed before the residuals say: low-passed at 2 Hz and read at 10 Hz, white noise alone
#: gives an AR(1) factor near 4, and road bank and a curve that misfits over a corner add to it;
#: 10 keeps the first blocks' intervals on the wide side.
INITIAL_VIF = 10.0
#: Weight of :data:`INITIAL_VIF` against the estimate, in 10 s chunks.
VIF_PRIOR_CHUNKS = 8.0
#: Chunk of the batch-means factor [samples] (10 s at 10 Hz), and the batches a length needs to
#: count (the batch fit's ``MIN_BATCHES``).
CHUNK = 100
#: Batch lengths of the batch-means factor [samples]: 10 s, a block (30 s), two blocks (60 s),
#: the batch fit's ``INFLATION_BLOCKS``.
BATCHES = (100, 300, 600)
MIN_CHUNKS = 8


class ResidualMoments(eqx.Module):
    """Running sums of one equation's residuals for its VIF (module docstring).

    Attributes
    ----------
    count, total, squares, lagged : Float[Array, ""]
        Samples, Σr, Σr², Σ r_t r_(t−1) over neighbouring valid samples.
    batches, batch_total, batch_squares : Float[Array, " levels"]
        Per batch length of :data:`BATCHES` (10, 30, 60 s): batches with at least half their
        samples valid, Σ of their means, Σ of their squares.
    pending_sum, pending_count : Float[Array, ""]
        Σr and samples of the block before, while a 60 s batch is half full.
    pending : Bool[Array, ""]
        Whether a 60 s batch is half full.
    sizes : Float[Array, " levels"]
        The batch lengths [samples]: 10 s, a block, two blocks.
    """

    count: Float[Array, ""]
    total: Float[Array, ""]
    squares: Float[Array, ""]
    lagged: Float[Array, ""]
    batches: Float[Array, " levels"]
    batch_total: Float[Array, " levels"]
    batch_squares: Float[Array, " levels"]
    pending_sum: Float[Array, ""]
    pending_count: Float[Array, ""]
    pending: Bool[Array, ""]
    sizes: Float[Array, " levels"]

    @classmethod
    def empty(cls, dtype) -> ResidualMoments:
        zero = jnp.zeros((), dtype)
        levels = jnp.zeros(len(BATCHES), dtype)
        sizes = jnp.asarray(BATCHES, dtype)
        return cls(
            zero, zero, zero, zero, levels, levels, levels, zero, zero, jnp.array(False), sizes
        )

    def add(self, r: Float[Array, " n"], mask: Bool[Array, " n"]) -> ResidualMoments:
        """These sums with a block's residuals ``r`` on ``mask`` added (a block is 30 s: three
        10 s batches, one 30 s batch, half of a 60 s batch)."""
        x = jnp.where(mask, r, 0.0)
        both = mask[1:] & mask[:-1]
        dtype = x.dtype
        n = x.shape[0] - x.shape[0] % CHUNK
        chunk_sum = jnp.sum(x[:n].reshape(-1, CHUNK), axis=1)
        chunk_count = jnp.sum(mask[:n].reshape(-1, CHUNK), axis=1).astype(dtype)
        block_sum, block_count = jnp.sum(x), jnp.sum(mask).astype(dtype)
        pair_sum, pair_count = self.pending_sum + block_sum, self.pending_count + block_count

        def level(sums, counts, size, when=True):
            counted = when & (counts >= size // 2)
            means = jnp.where(counted, sums / jnp.maximum(counts, 1.0), 0.0)
            return jnp.sum(counted).astype(dtype), jnp.sum(means), jnp.sum(means**2)

        width = x.shape[0]
        levels = [
            level(chunk_sum, chunk_count, CHUNK),
            level(block_sum, block_count, width),
            level(pair_sum, pair_count, 2 * width, when=self.pending),
        ]
        added = [jnp.stack(v) for v in zip(*levels, strict=True)]
        return ResidualMoments(
            count=self.count + block_count,
            total=self.total + block_sum,
            squares=self.squares + jnp.sum(x**2),
            lagged=self.lagged + jnp.sum(jnp.where(both, x[1:] * x[:-1], 0.0)),
            batches=self.batches + added[0],
            batch_total=self.batch_total + added[1],
            batch_squares=self.batch_squares + added[2],
            pending_sum=jnp.where(self.pending, 0.0, block_sum),
            pending_count=jnp.where(self.pending, 0.0, block_count),
            pending=~self.pending,
            sizes=jnp.asarray([CHUNK, width, 2 * width], dtype),
        )

    def settled(self) -> Bool[Array, ""]:
        """Whether :data:`MIN_CHUNKS` batches of a block's length (30 s) are in: before that the
        slow correlations that dominate on real roads are not measured, and the intervals,
        however narrow, are not yet trusted (readiness waits for it)."""
        return self.batches[1] >= MIN_CHUNKS

    def inflation(self) -> Float[Array, ""]:
        """The VIF in use: the estimate (AR(1) and batch means, the batch fit's rule), blended
        with :data:`INITIAL_VIF` over the first :data:`VIF_PRIOR_CHUNKS` 10 s of data."""
        n = jnp.maximum(self.count, 1.0)
        centre = self.total / n
        var = jnp.maximum(self.squares / n - centre**2, 1e-30)
        phi = jnp.clip((self.lagged / n - centre**2) / var, 0.0, 0.995)
        ar1 = (1.0 + phi) / (1.0 - phi)
        batches = jnp.maximum(self.batches, 1.0)
        batch_var = self.batch_squares / batches - (self.batch_total / batches) ** 2
        factors = jnp.where(self.batches >= MIN_CHUNKS, self.sizes * batch_var / var, 1.0)
        estimate = jnp.where(
            self.count >= 20, jnp.maximum(jnp.maximum(ar1, jnp.max(factors)), 1.0), 1.0
        )
        seen = self.count / CHUNK
        return (VIF_PRIOR_CHUNKS * INITIAL_VIF + seen * estimate) / (VIF_PRIOR_CHUNKS + seen)


__all__ = [
    "BATCHES",
    "CHUNK",
    "INITIAL_VIF",
    "MIN_CHUNKS",
    "VIF_PRIOR_CHUNKS",
    "ResidualMoments",
]
