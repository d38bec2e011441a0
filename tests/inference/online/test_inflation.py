"""The running variance inflation equals the batch fit's batch-means estimate."""

import jax.numpy as jnp
import numpy as np

from tyrebayes.inference.online.inflation import (
    accrue_residuals,
    empty_inflation,
    estimated_inflation,
)
from tyrebayes.inference.tyre.window_correlation import variance_inflation


def test_running_sums_equal_batch_means():
    rng = np.random.default_rng(1)
    z = np.repeat(rng.standard_normal(1400), 2) + 0.1  # pairs: VIF ≈ 2, a mean to centre
    used = rng.uniform(size=z.size) > 0.2  # windows that are not slip windows in between
    sums = empty_inflation()
    width = 121
    for start in range(0, z.size, width):
        chunk = slice(start, start + width)
        zz = np.zeros(width)
        uu = np.zeros(width, dtype=bool)
        zz[: z[chunk].size] = z[chunk]
        uu[: z[chunk].size] = used[chunk]
        sums = accrue_residuals(sums, jnp.asarray(zz), jnp.asarray(uu))
    np.testing.assert_allclose(
        float(estimated_inflation(sums)), variance_inflation(z[used]), rtol=1e-9
    )
