"""NaN-aware smoothing and differentiation."""

from __future__ import annotations

import numpy as np
import pytest

from tyrebayes.streams.filters import nan_moving_average, smoothed_derivative, window_samples


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
