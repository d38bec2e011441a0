"""The online lateral estimator's residual VIF against the batch fit's rule."""

import jax.numpy as jnp
import numpy as np

from tyrebayes.inference.lateral.inflation import residual_inflation
from tyrebayes.inference.online.lateral_vif import (
    INITIAL_VIF,
    MIN_CHUNKS,
    VIF_PRIOR_CHUNKS,
    ResidualMoments,
)


def test_residual_vif_follows_the_batch_rule():
    rng = np.random.default_rng(0)
    phi, n = 0.8, 20 * 300
    x = np.zeros(n)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + rng.normal()
    moments = ResidualMoments.empty(jnp.float64)
    for block in x.reshape(20, 300):
        moments = moments.add(jnp.asarray(block), jnp.ones(300, bool))
    batch = residual_inflation(x, np.ones(n, bool))
    seen = n / 100
    expected = (VIF_PRIOR_CHUNKS * INITIAL_VIF + seen * batch) / (VIF_PRIOR_CHUNKS + seen)
    # Stated tolerance: 15 % (clock batches and the batch fit's compacted ones differ slightly).
    assert abs(float(moments.inflation()) / expected - 1.0) < 0.15
    assert int(moments.batches[2]) == 10  # ten 60 s batches from twenty 30 s blocks


def test_settled_after_enough_block_batches():
    moments = ResidualMoments.empty(jnp.float64)
    r, mask = jnp.asarray(np.random.default_rng(1).normal(size=300)), jnp.ones(300, bool)
    for _ in range(MIN_CHUNKS - 1):
        moments = moments.add(r, mask)
    assert not bool(moments.settled())
    assert bool(moments.add(r, mask).settled())
