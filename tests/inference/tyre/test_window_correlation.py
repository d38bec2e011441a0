"""Variance inflation of correlated window errors and the slip weights it gives."""

import numpy as np
import pytest

from tyrebayes.inference.tyre.window_correlation import (
    MAX_INFLATION,
    slip_weights,
    variance_inflation,
)


def ar1(phi: float, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    e = rng.standard_normal(n) * np.sqrt(1 - phi**2)
    z = np.empty(n)
    z[0] = rng.standard_normal()
    for i in range(1, n):
        z[i] = phi * z[i - 1] + e[i]
    return z


def test_independent_errors_are_not_inflated():
    # 16,000 values = 400 blocks: the estimate's sd is about √(2/400) = 0.07.
    assert variance_inflation(np.random.default_rng(0).standard_normal(16_000)) < 1.2


@pytest.mark.parametrize("phi", [0.38, 0.6])
def test_ar1_errors_inflate_by_one_plus_phi_over_one_minus_phi(phi):
    expected = (1 + phi) / (1 - phi)
    # Tolerance 15 %: three sds of the batch-means estimate with 400 blocks, plus its small
    # downward bias at 40-window blocks.
    assert variance_inflation(ar1(phi, 16_000, seed=1)) == pytest.approx(expected, rel=0.15)


def test_too_few_blocks_or_a_misfit_are_bounded():
    assert variance_inflation(np.random.default_rng(0).standard_normal(100)) == 1.0
    drift = np.linspace(-1.0, 1.0, 8000)  # residuals that are a trend, not noise
    assert variance_inflation(drift) == MAX_INFLATION


def test_weights_are_per_drive_and_only_on_slip_windows():
    z = np.concatenate([ar1(0.6, 8000, seed=2), np.random.default_rng(3).standard_normal(8000)])
    drive = np.repeat([0, 1], 8000)
    slip_window = np.ones(16_000, dtype=bool)
    slip_window[100] = False  # e.g. an ABS window
    weights, inflation = slip_weights(z, slip_window, drive, 2)
    assert inflation[0] > 3.0 and inflation[1] < 1.3
    assert weights[100] == 1.0
    assert weights[0] == pytest.approx(1 / inflation[0])
    assert weights[-1] == pytest.approx(1 / inflation[1])
