"""Quantisation and white-noise estimates."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from tyrebayes.streams.filters import nan_moving_average
from tyrebayes.streams.noise import local_noise_sd, quantisation_step, white_noise_sd


def test_quantisation_of_can_wheel_speed():
    rng = np.random.default_rng(0)
    step = 0.01 / 3.6 / 0.35  # 0.01 km/h at 0.35 m
    x = np.round((50 + np.cumsum(rng.normal(0, 0.01, 20_000))) / step) * step
    assert quantisation_step(x) == pytest.approx(step, rel=1e-9)


def test_continuous_signal_has_no_step():
    x = np.random.default_rng(1).normal(size=10_000)
    assert quantisation_step(x) == 0.0
    assert quantisation_step(np.array([1.0, 2.0, np.nan])) == 0.0


def test_white_noise_sd_on_a_smooth_signal():
    t = np.arange(50_000) * 0.01
    x = 10 * np.sin(2 * np.pi * 0.1 * t) + np.random.default_rng(2).normal(0, 0.05, t.size)
    # 50 000 samples: the MAD-based sd is within a few percent.
    assert white_noise_sd(x) == pytest.approx(0.05, rel=0.05)


def test_white_noise_sd_floors_at_quantisation():
    x = np.round(np.linspace(0, 1, 5000) / 0.1) * 0.1  # steps, MAD of Δ² is zero
    assert white_noise_sd(x, 0.1) == pytest.approx(0.1 / np.sqrt(12))
    assert np.isnan(white_noise_sd(np.ones(5)))


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.9])
def test_local_noise_sd_of_smoothed_coloured_noise(phi):
    # AR(1) noise: the sd of its 21-sample average is what the features need. White and mildly
    # coloured noise within 5 %; strongly coloured (phi 0.9, 10-sample memory) within 15 %
    # (the part slower than the 1 s high-pass is missed), where sd/sqrt(window) is off by 3.7x.
    x = lfilter([1.0], [1.0, -phi], np.random.default_rng(3).normal(0, 1, 200_000))
    true = np.std(nan_moving_average(x, 21)[100:-100])
    got = float(np.nanmedian(local_noise_sd(x, 21, 1001)))
    assert got == pytest.approx(true, rel=0.05 if phi < 0.9 else 0.15)


def test_local_noise_sd_ignores_slow_signal_and_follows_roughness():
    t = np.arange(100_000) * 0.01
    rng = np.random.default_rng(4)
    level = np.where(t < 500, 0.1, 0.3)  # a rough stretch in the second half
    x = 5 * np.sin(2 * np.pi * 0.13 * t) + level * rng.normal(size=t.size)
    got = local_noise_sd(x, 21, 1001)
    assert np.median(got[t < 450]) == pytest.approx(0.1 / np.sqrt(21), rel=0.1)
    assert np.median(got[t > 550]) == pytest.approx(0.3 / np.sqrt(21), rel=0.1)
