"""NaN-aware smoothing and differentiation."""

from __future__ import annotations

import numpy as np
import pytest

from tyrebayes.streams.filters import (
    PrefixSums,
    nan_moving_average,
    smoothed_derivative,
    strided_window_mean,
    window_samples,
)


def test_moving_average_matches_convolution_without_nan():
    rng = np.random.default_rng(0)
    x = rng.normal(size=500)
    got = nan_moving_average(x, 11)
    ref = np.convolve(x, np.ones(11) / 11, mode="valid")
    np.testing.assert_allclose(got[5:-5], ref, rtol=1e-12)


def test_moving_average_skips_nan_and_reports_empty_windows():
    x = np.arange(20.0)
    x[5:12] = np.nan
    got = nan_moving_average(x, 3)
    assert np.isnan(got[7:10]).all()  # windows with no valid sample
    assert got[5] == pytest.approx(4.0)  # only x[4] is valid around index 5
    assert np.isfinite(got[:6]).all() and np.isfinite(got[11:]).all()


def test_derivative_of_a_ramp_and_noise_gain():
    t = np.arange(1000) * 0.01
    x = 2.0 * t + 1.0
    np.testing.assert_allclose(smoothed_derivative(x, 0.01, 21)[20:-20], 2.0, rtol=1e-9)
    noise = np.random.default_rng(1).normal(0, 0.1, 100_000)
    # Boxcar of w then central difference: sd ≈ sd_x · sqrt(2) / (2 dt w) · sqrt(2) for white noise.
    sd = np.std(smoothed_derivative(noise, 0.01, 21)[50:-50])
    assert sd == pytest.approx(0.1 / (0.01 * 21), rel=0.15)


def test_window_samples_is_odd():
    assert window_samples(0.2, 100.0) == 21
    assert window_samples(0.2, 50.0) == 11
    assert window_samples(0.001, 50.0) == 1
    with pytest.raises(ValueError, match="window >= 1"):
        nan_moving_average(np.zeros(3), 0)


@pytest.mark.parametrize("half", [1, 3, 10])
@pytest.mark.parametrize("n", [7, 1000, 1003])
def test_prefix_sums_and_strided_means_equal_the_moving_average(half, n):
    rng = np.random.default_rng(n + half)
    x = rng.normal(30.0, 1.0, n)
    table = np.column_stack([x, -x, x])
    for gaps in ([], [2, 3, 400, 401, 402, 999], list(range(100, 300))):
        y = x.copy()
        y[[g for g in gaps if g < n]] = np.nan
        reference = nan_moving_average(y, 2 * half + 1)
        prefix = PrefixSums.of(y)
        # Prefix sums: the moving average to the last bit, at every sample or every step-th.
        np.testing.assert_array_equal(prefix.window_mean(half), reference)
        np.testing.assert_array_equal(prefix.window_mean(half, step=half), reference[::half])
        # Segment sums: the same numbers to rounding, NaN in the same places.
        strided = strided_window_mean(y.copy(), half, prefix, overwrite_input=True)
        np.testing.assert_allclose(strided, reference[::half], rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(np.isnan(strided), np.isnan(reference[::half]))
    # Columns with the same NaN share their counts; a 2-D average is the columns' own.
    table[[5, 6], :] = np.nan
    np.testing.assert_array_equal(
        nan_moving_average(table, 2 * half + 1)[:, 1], nan_moving_average(table[:, 1], 2 * half + 1)
    )
