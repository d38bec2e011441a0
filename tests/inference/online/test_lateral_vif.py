"""The online lateral estimator's residual VIF against the batch fit's rule."""

import jax
import jax.numpy as jnp
import numpy as np

from tyrebayes.inference.lateral.inflation import residual_inflation
from tyrebayes.inference.online.lateral_statistics import equation_moments
from tyrebayes.inference.online.lateral_vif import (
    INITIAL_VIF,
    MIN_CHUNKS,
    VIF_PRIOR_CHUNKS,
    inflation,
    settled,
)

SIZES = jnp.asarray([100.0, 300.0, 600.0])


def _summed(moments):
    """Per-block moments summed over the blocks."""
    return jax.tree_util.tree_map(lambda x: jnp.sum(x, axis=0), moments)


def test_residual_vif_follows_the_batch_rule():
    """Residuals e = z · c of AR(1) noise: the VIF from the moments at c is the batch fit's of
    the residuals, blended with the initial VIF."""
    rng = np.random.default_rng(0)
    phi, n = 0.8, 20 * 300
    x = np.zeros(n)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + rng.normal()
    # Two regressors: the residual is x − 0.5 w for a second, independent series w.
    w = rng.normal(size=n)
    z = np.stack([x + 0.5 * w, w], axis=-1).reshape(20, 300, 2)
    moments = _summed(equation_moments(jnp.asarray(z), jnp.ones((20, 300), bool)))
    vif = inflation(moments, jnp.asarray([1.0, -0.5]), SIZES)
    batch = residual_inflation(x, np.ones(n, bool))
    seen = n / 100
    expected = (VIF_PRIOR_CHUNKS * INITIAL_VIF + seen * batch) / (VIF_PRIOR_CHUNKS + seen)
    # Stated tolerance: 15 % (clock batches and the batch fit's compacted ones differ slightly).
    assert abs(float(vif) / expected - 1.0) < 0.15
    assert int(moments.batches[2]) == 10  # ten 60 s batches from twenty 30 s blocks


def test_settled_after_enough_block_batches():
    assert not bool(settled(jnp.asarray([MIN_CHUNKS - 1.0, 20.0])))
    assert bool(settled(jnp.asarray([MIN_CHUNKS, MIN_CHUNKS], float)))
