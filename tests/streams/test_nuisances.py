"""Nuisance estimators: IMU offset, radius ratios, speed scale."""

from __future__ import annotations

import numpy as np
import pytest

from tyrebayes.streams.nuisances import (
    estimate_ax_offset,
    estimate_radius_ratios,
    estimate_speed_scale,
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
