"""Nuisance estimators: IMU offset and gain, radius ratios, speed scale."""

from __future__ import annotations

import numpy as np
import pytest

from tyrebayes.streams.nuisances import (
    estimate_ax_gain,
    estimate_ax_offset,
    estimate_radius_ratios,
    estimate_speed_scale,
    imu_gain_correction,
)


def test_ax_offset_and_its_standard_error():
    rng = np.random.default_rng(0)
    n, rate = 60_000, 100.0
    dv = np.sin(np.arange(n) / 500)
    ax = dv - 0.4 + rng.normal(0, 0.1, n)
    off, se = estimate_ax_offset(ax, dv, np.ones(n, bool), rate)
    assert off == pytest.approx(-0.4, abs=0.01)
    # 600 s at a 1 s correlation time: se ≈ 1.25 · 0.1 / sqrt(600).
    assert se == pytest.approx(1.2533 * 0.1 / np.sqrt(600), rel=0.1)


def test_radius_ratios_invert_speed_ratios():
    radius = np.array([1.002, 0.999, 1.0, 0.999])
    v = np.full((2000, 4), 20.0) / radius * radius.mean()
    ratio, sd, seconds = estimate_radius_ratios(v, np.ones(2000, bool), 100.0)
    # Normalised by the harmonic mean of the radii (a mean of speeds): differs from the
    # arithmetic mean at second order, (0.1 %)² ~ 1e-6.
    np.testing.assert_allclose(ratio, radius / radius.mean(), rtol=1e-5)
    assert seconds == pytest.approx(20.0)
    ratio, _, _ = estimate_radius_ratios(v, np.zeros(2000, bool), 100.0)
    assert np.isnan(ratio).all()  # no free rolling, no estimate


def test_speed_scale():
    ref = np.linspace(5, 30, 1000)
    scale, se = estimate_speed_scale(0.99 * ref, ref, np.ones(1000, bool), 100.0)
    assert scale == pytest.approx(0.99) and se == pytest.approx(0.0, abs=1e-12)


def test_ax_gain_and_its_standard_error_are_calibrated():
    """Slope of ax on dV/dt under slowly varying grade: the estimate's z-scores have sd ~1."""
    n, rate = 36_000, 100.0
    t = np.arange(n) / rate
    z = []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        dv = np.sin(t / 4.0 + seed) + 0.5 * np.sin(t / 1.3)
        # Grade as a random walk smoothed over ~10 s, plus white sensor noise.
        grade = np.convolve(rng.normal(0, 0.05, n), np.ones(1000) / 1000, "same")
        ax = 0.8 * (dv + 9.81 * grade) - 0.3 + rng.normal(0, 0.2, n)
        gain, se = estimate_ax_gain(ax, dv, np.ones(n, bool), rate)
        assert gain == pytest.approx(0.8, abs=0.02)
        z.append((gain - 0.8) / se)
    assert 0.7 < np.std(z) < 1.4


def test_ax_gain_without_accelerations_is_nan():
    gain, se = estimate_ax_gain(np.full(1000, 0.2), np.zeros(1000), np.ones(1000, bool), 100.0)
    assert np.isnan(gain) and np.isnan(se)


@pytest.mark.parametrize(
    ("gain", "sd", "uncalibrated"),
    [(1.004, 0.003, False), (1.02, 0.005, False), (0.79, 0.02, True), (1.3, 0.02, True)],
)
def test_imu_gain_is_corrected_only_when_clearly_off(gain, sd, uncalibrated):
    c = imu_gain_correction(gain, sd)
    assert c.uncalibrated is uncalibrated
    if uncalibrated:
        assert c.p_uncalibrated > 0.99
        assert c.applied == pytest.approx(gain, rel=0.01)
        assert c.applied_log_sd == pytest.approx(sd / gain, rel=0.05)
    else:
        # A calibrated IMU's gain is the tyre model's business: next to nothing applied here.
        assert c.applied == pytest.approx(1.0, abs=1e-3) and c.applied_log_sd < 5e-3


def test_imu_gain_correction_is_continuous_in_the_evidence():
    """Between the two kinds of IMU the applied gain moves smoothly and its spread is widest."""
    gains = np.linspace(0.85, 1.0, 61)
    applied = np.array([imu_gain_correction(g, 0.02).applied for g in gains])
    assert np.all(np.diff(applied) > 0) and np.max(np.abs(np.diff(applied))) < 0.01
    middle = imu_gain_correction(0.925, 0.02)
    assert 0.05 < middle.p_uncalibrated < 0.95
    assert middle.applied_log_sd > imu_gain_correction(0.8, 0.02).applied_log_sd


def test_imu_gain_without_information_is_left_alone():
    c = imu_gain_correction(float("nan"), float("nan"))
    assert c.applied == 1.0 and c.applied_log_sd == 0.0
    assert c.p_uncalibrated == pytest.approx(0.05)
    # A wide estimate cannot overrule the calibrated prior either.
    assert not imu_gain_correction(0.9, 0.2).uncalibrated
