"""The residuals' variance inflation factor: white noise near 1, slow correlation far above."""

import numpy as np

from tyrebayes.inference.lateral.inflation import residual_inflation


def test_residual_inflation_sees_slow_correlation():
    rng = np.random.default_rng(0)
    white = rng.normal(size=20000)
    assert residual_inflation(white, np.ones(20000, bool)) < 1.5
    slow = np.repeat(rng.normal(size=200), 100) + 0.1 * white  # 10 s steps at 10 Hz
    assert residual_inflation(slow, np.ones(20000, bool)) > 50
