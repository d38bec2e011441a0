"""Tests of the planned speed/lateral/grade profiles."""

from __future__ import annotations

import numpy as np
import pytest

from tyrebayes.physics.vehicle import GRAVITY_MPS2
from tyrebayes.simulate.profiles import (
    LAT_LABELS,
    LONG_LABELS,
    MIN_CURVE_RADIUS_M,
    ProfileOptions,
    make_profile,
    ou_process,
    profile_from_trace,
    smooth_noise,
    surface_speed_limit_kmh,
)


@pytest.fixture(scope="module")
def hour():
    opts = ProfileOptions(n_abs_events=6, hard_brakes_per_hour=10.0)
    return make_profile(
        np.random.default_rng(0),
        duration_s=3600.0,
        sample_rate_hz=50.0,
        mu_surface=1.0,
        options=opts,
    )


def test_profile_is_continuous_and_physical(hour):
    p = hour
    assert p.speed_mps.shape == (180_000,)
    assert p.speed_mps.min() >= 0.0
    assert p.speed_mps.max() * 3.6 <= surface_speed_limit_kmh(1.0) + 5.0  # + cruise wander
    # Continuous speed: no step larger than a hard brake at 9 m/s² over one sample.
    assert np.abs(np.diff(p.speed_mps)).max() < 9.5 * p.dt_s
    not_abs = p.long_label != LONG_LABELS.index("abs")
    # Outside ABS the planned accelerations stay within 0.75 μ g.
    assert np.abs(p.accel_mps2[not_abs]).max() < 0.76 * GRAVITY_MPS2
    # Curves no tighter than the minimum radius.
    assert np.all(np.abs(p.ay_mps2) <= p.speed_mps**2 / MIN_CURVE_RADIUS_M + 1e-12)


def test_profile_events_and_labels(hour):
    p = hour
    assert len(p.abs_events) == 6
    for ev in p.abs_events:
        assert np.all(p.long_label[ev.start : ev.stop] == LONG_LABELS.index("abs"))
        assert np.all(p.ay_mps2[ev.start : ev.stop] == 0.0)  # straight-line braking
        assert p.speed_mps[ev.start] > 15.0
        assert ev.recovery_stop > ev.stop
    counts = np.bincount(p.long_label, minlength=len(LONG_LABELS))
    for label in ("cruise", "accelerate", "decelerate", "hard_brake", "stop"):
        assert counts[LONG_LABELS.index(label)] > 0, label
    lat = np.bincount(p.lat_label, minlength=len(LAT_LABELS))
    assert lat[LAT_LABELS.index("corner")] > 0 and lat[LAT_LABELS.index("lane_change")] > 0


def test_low_friction_profile_is_gentler():
    rng = np.random.default_rng(1)
    ice = make_profile(rng, duration_s=1800.0, sample_rate_hz=50.0, mu_surface=0.12)
    assert np.abs(ice.accel_mps2).max() < 0.76 * 0.12 * GRAVITY_MPS2 + 0.05
    assert np.abs(ice.grade_rad).max() <= 0.2 * 0.12
    assert ice.speed_mps.max() * 3.6 < surface_speed_limit_kmh(0.12) + 3.0
    assert np.abs(ice.ay_mps2).max() <= 0.5 * 0.12 * GRAVITY_MPS2 + 0.3  # + road-curvature noise


def test_noise_processes():
    x = ou_process(np.random.default_rng(2), 400_000, 0.01, 2.0, 0.7)
    assert x.std() == pytest.approx(0.7, rel=0.1)
    # AR(1) correlation over one time constant is 1/e.
    lag = 200
    assert np.corrcoef(x[:-lag], x[lag:])[0, 1] == pytest.approx(np.exp(-1), abs=0.05)
    y = smooth_noise(np.random.default_rng(3), 400_000, 0.01, 2.0, 0.7)
    assert y.std() == pytest.approx(0.7, rel=0.15)
    assert np.std(np.diff(y)) / 0.01 < 0.7  # differentiable: derivative sd ~ sd / tau


def test_profile_from_trace_replays_speed():
    t = np.linspace(0, 30, 301)
    v = 15 + 2 * np.sin(t / 3)
    p = profile_from_trace(t, v, sample_rate_hz=100.0, ay_mps2=np.full_like(t, 1.5))
    assert p.speed_mps.shape == (3000,)
    np.testing.assert_allclose(
        p.speed_mps[100:-100], np.interp(p.time_s[100:-100], t, v), atol=0.01
    )
    assert p.lat_label[1500] == LAT_LABELS.index("corner")
    with pytest.raises(ValueError, match="strictly increasing"):
        profile_from_trace(t[::-1], v, sample_rate_hz=100.0)


def test_bad_profile_arguments():
    with pytest.raises(ValueError, match="mu_surface"):
        make_profile(np.random.default_rng(0), duration_s=10.0, sample_rate_hz=50.0, mu_surface=0.0)
    with pytest.raises(ValueError, match="stop_probability"):
        ProfileOptions(stop_probability=2.0)
