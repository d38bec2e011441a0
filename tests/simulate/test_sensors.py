"""Tests of the sensor model: each effect appears in the logged stream as specified."""

from __future__ import annotations

import equinox as eqx
import numpy as np
import pytest

from tyrebayes.physics.vehicle import GRAVITY_MPS2
from tyrebayes.simulate.sensors import (
    SensorModel,
    SensorTruth,
    draw_sensor_truth,
    measure,
    sample_times,
)
from tyrebayes.streams.noise import quantisation_step, white_noise_sd

N = 20_000
RATE = 100.0


def _signals(speed: float = 20.0, accel: float = 0.0, grade: float = 0.0) -> dict:
    t = np.arange(N) / RATE
    v = np.full(N, speed)
    return dict(
        time_s=t,
        wheel_speed_radps=np.full((N, 4), speed / 0.35),
        accel_mps2=np.full(N, accel),
        ay_mps2=np.zeros(N),
        grade_rad=np.full(N, grade),
        yaw_rate_radps=np.zeros(N),
        steering_wheel_angle_rad=np.zeros(N),
        speed_mps=v,
        ambient_c=3.2,
    )


def _offsets(pitch: float = 0.0, bias: tuple[float, float] = (0.0, 0.0)) -> SensorTruth:
    return SensorTruth(
        radius_error=np.zeros(4),
        imu_bias_mps2=np.asarray(bias),
        mounting_pitch_rad=pitch,
        yaw_rate_bias_radps=0.0,
        wheel_speed_step_radps=0.01 / 3.6 / 0.35,
    )


def test_ideal_sensor_passes_signals_through():
    rng = np.random.default_rng(0)
    sig = _signals(accel=0.5, grade=0.03)
    df = measure(rng, SensorModel.ideal(), _offsets(), **sig)
    np.testing.assert_allclose(df["wheel_speed_fl"], sig["wheel_speed_radps"][:, 0])
    np.testing.assert_allclose(df["ax"], 0.5 + GRAVITY_MPS2 * np.sin(0.03))
    np.testing.assert_allclose(df["az"], -0.5 * 0.0 + GRAVITY_MPS2 * np.cos(0.03))
    assert not df.isna().any().any()


def test_mounting_pitch_bias_and_gain_enter_ax():
    rng = np.random.default_rng(1)
    ideal = SensorModel.ideal()
    offsets = eqx.tree_at(lambda o: o.ax_gain, _offsets(pitch=-0.05, bias=(0.1, -0.2)), 0.8)
    df = measure(rng, ideal, offsets, **_signals(accel=1.0))
    expected = 0.8 * (1.0 * np.cos(-0.05) + GRAVITY_MPS2 * np.sin(-0.05)) + 0.1
    np.testing.assert_allclose(df["ax"], expected, atol=1e-12)
    np.testing.assert_allclose(df["ay"], -0.2, atol=1e-12)


def test_body_pitch_over_reads_ax_by_the_pitch_gain():
    """Squat/dive of k rad per m/s² makes a level IMU read a_x (1 + g·k) to first order."""
    k = 0.002
    for accel in (-6.0, 2.0):
        df = measure(
            np.random.default_rng(1),
            SensorModel.ideal(),
            _offsets(),
            **_signals(accel=accel),
            pitch_gradient_rad_per_mps2=k,
        )
        np.testing.assert_allclose(df["ax"], accel * (1 + GRAVITY_MPS2 * k), rtol=2e-4)


def test_ax_gain_is_drawn_per_drive_around_the_sensor_gain():
    sensor = SensorModel(ax_gain=0.9, ax_gain_sd=0.01)
    gains = [draw_sensor_truth(np.random.default_rng(s), sensor, 0.3).ax_gain for s in range(400)]
    assert np.mean(gains) == pytest.approx(0.9, abs=0.002)
    assert np.std(gains) / 0.9 == pytest.approx(0.01, rel=0.15)


def _fields(model: SensorModel) -> dict:
    return {k: getattr(model, k) for k in model.__dataclass_fields__}


def test_default_noise_levels_and_quantisation():
    """White-noise estimates land near the levels measured on the real RAV4 log."""
    rng = np.random.default_rng(2)
    df = measure(rng, SensorModel(), _offsets(), **_signals())
    step = quantisation_step(df["wheel_speed_fl"].dropna().to_numpy())
    assert step == pytest.approx(0.01 / 3.6 / 0.35, rel=1e-6)
    # Real log (benchmarks/real_vs_sim.py): wheels 0.043-0.062 rad/s, ax 0.26, yaw 0.0014.
    wheel = white_noise_sd(df["wheel_speed_fl"].to_numpy())
    assert 0.03 < wheel < 0.1
    assert 0.15 < white_noise_sd(df["ax"].to_numpy()) < 0.4
    assert white_noise_sd(df["yaw_rate"].to_numpy()) == pytest.approx(0.0015, rel=0.15)


def test_noise_vanishes_at_standstill_and_speeds_are_nonnegative():
    rng = np.random.default_rng(3)
    sig = _signals(speed=0.0)
    df = measure(
        rng, SensorModel(drop_probability=0.0, dropout_bursts_per_hour=0.0), _offsets(), **sig
    )
    wheels = df[["wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl", "wheel_speed_rr"]]
    assert (wheels.to_numpy() == 0.0).all()


def test_bumps_hit_front_then_rear():
    """A bump reaches the rear wheels one wheelbase after the front ones."""
    rng = np.random.default_rng(4)
    ideal = _fields(SensorModel.ideal())
    sensor = SensorModel(**{**ideal, "bumps_per_km": 5.0, "bump_amplitude_radps": 1.0})
    sig = _signals(speed=20.0)
    df = measure(rng, sensor, _offsets(), wheelbase_m=2.0, **sig)
    dev = df[["wheel_speed_fl", "wheel_speed_rl"]].to_numpy() - 20.0 / 0.35
    assert np.abs(dev).max() > 0.1
    front, rear = np.abs(dev[:, 0]), np.abs(dev[:, 1])
    lags = np.arange(0, 40)
    lag = lags[np.argmax([np.dot(rear[k:], front[: N - k]) for k in lags])]
    assert lag == pytest.approx(2.0 / 20.0 * RATE, abs=1)


def test_gnss_hold_and_interpolation():
    rng = np.random.default_rng(5)
    sig = _signals()
    sig["speed_mps"] = np.linspace(10, 20, N)
    held = measure(
        rng, SensorModel(drop_probability=0.0, dropout_bursts_per_hour=0.0), _offsets(), **sig
    )
    changes = np.mean(np.diff(held["speed_reference"].to_numpy()) != 0)
    assert changes == pytest.approx(0.2, abs=0.01)  # 20 Hz fixes at 100 Hz
    interp = measure(
        rng,
        SensorModel(gnss_hold=False, drop_probability=0.0, dropout_bursts_per_hour=0.0),
        _offsets(),
        **sig,
    )
    assert np.mean(np.diff(interp["speed_reference"].to_numpy()) != 0) > 0.95


def test_dropouts_are_nan_and_time_never():
    rng = np.random.default_rng(6)
    df = measure(
        rng,
        SensorModel(drop_probability=0.01, dropout_bursts_per_hour=0.0),
        _offsets(),
        **_signals(),
    )
    frac = df.drop(columns="time").isna().mean()
    assert (frac > 0.005).all() and (frac < 0.02).all()
    assert not df["time"].isna().any()


def test_draw_sensor_truth_uses_means_and_sds():
    rng = np.random.default_rng(7)
    fixed = SensorModel(
        radius_error_mean=(0.01, 0.0, -0.01, 0.0),
        radius_error_sd=0.0,
        mounting_pitch_mean_rad=0.02,
        mounting_pitch_sd_rad=0.0,
    )
    off = draw_sensor_truth(rng, fixed, 0.3)
    np.testing.assert_array_equal(off.radius_error, [0.01, 0.0, -0.01, 0.0])
    assert off.mounting_pitch_rad == 0.02
    assert off.wheel_speed_step_radps == pytest.approx(0.01 / 3.6 / 0.3)


def test_sample_times_jitter():
    t = sample_times(np.random.default_rng(8), 10_000, 83.0, 0.45)
    dt = np.diff(t)
    assert dt.min() > 0
    assert dt.std() / dt.mean() == pytest.approx(0.45 * 2 / np.sqrt(12) * np.sqrt(2), rel=0.1)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"timing_jitter": 0.5}, "timing_jitter"),
        ({"drop_probability": 1.5}, "drop_probability"),
        ({"wheel_vibration_radps": (0.1, float("nan"))}, "wheel_vibration_radps"),
        ({"radius_error_sd": -0.1}, "radius_error_sd"),
        ({"accel_noise_mps2": (0.1, -0.1, 0.1)}, "vibration amplitudes"),
    ],
)
def test_invalid_sensor_models(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SensorModel(**kwargs)


def test_scale_noise_scales_measured_noise():
    from tyrebayes.simulate.sensors import scale_noise

    sig = _signals()
    quiet = SensorModel(wheel_speed_resolution_kmh=0.0, bumps_per_km=0.0)
    low = measure(np.random.default_rng(9), quiet, _offsets(), **sig)
    high = measure(np.random.default_rng(9), scale_noise(quiet, 3.0), _offsets(), **sig)
    ratio = np.nanstd(np.diff(high["ax"])) / np.nanstd(np.diff(low["ax"]))
    assert ratio == pytest.approx(3.0, rel=1e-6)  # same random draws, amplitudes × 3
    with pytest.raises(ValueError, match="factor"):
        scale_noise(quiet, -1.0)
