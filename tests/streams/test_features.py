"""Signal pipeline: features against closed-form truth, noise calibration, the real RAV4 log."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes._resources import data_dir
from tyrebayes.streams import (
    SEGMENT_REGIMES,
    compute_features,
    read_stream,
    speed_error,
    validate_stream,
)
from tyrebayes.streams.synthetic import synthetic_stream

VEHICLE = load_vehicle("compact_fwd")


@pytest.fixture(scope="module")
def synthetic():
    df, truth = synthetic_stream(VEHICLE, duration_s=120.0, rate_hz=100.0, seed=11)
    return compute_features(validate_stream(df, VEHICLE), VEHICLE), truth


@pytest.fixture(scope="module")
def real():
    vehicle = load_vehicle("suv_rav4")
    stream = validate_stream(read_stream(data_dir() / "comma2k19_rav4_segment.csv"), vehicle)
    return compute_features(stream, vehicle), stream


def test_vx_from_non_driven_wheels(synthetic):
    feats, truth = synthetic
    err = truth["radius_error"]
    rel = feats.vx_mps / truth["vx_mps"] - 1.0
    traction = feats.rho_driven > 0.02
    # In traction the rear wheels roll freely: V_x is off only by their mean radius error.
    expected = -(err[2] + err[3]) / 2
    assert np.nanmedian(rel[traction]) == pytest.approx(expected, abs=1e-4)


def test_slip_recovered_up_to_radius_offset(synthetic):
    feats, truth = synthetic
    err = truth["radius_error"]
    offset = (err[2] + err[3]) / 2 - (err[0] + err[1]) / 2  # rear over front radius mismatch
    diff = feats.slip_driven - truth["slip_driven_relative"]
    ok = feats.valid
    assert np.median(diff[ok]) == pytest.approx(offset, abs=2e-5)
    # Stated noise is calibrated: residuals over their stated sd have sd 1 (±20 %: 120 s of
    # 0.2 s-correlated samples give ~600 independent values, plus the 10 s local estimate).
    z = (diff[ok] - np.median(diff[ok])) / feats.slip_driven_sd[ok]
    assert np.std(z) == pytest.approx(1.0, rel=0.2)


def test_rho_and_noise(synthetic):
    feats, truth = synthetic
    ok = feats.valid
    diff = feats.rho_driven[ok] - truth["rho_driven"][ok]
    # 0.003: ax offset estimated to ~0.01 m/s² plus the small-δ approximation of the truth.
    assert abs(np.median(diff)) < 0.003
    z = (diff - np.median(diff)) / feats.rho_driven_sd[ok]
    assert np.std(z) == pytest.approx(1.0, rel=0.2)
    # The offset's error is one number per log, reported apart from the per-sample noise.
    assert 0 < feats.nuisances.rho_offset_sd < 0.05


def test_body_pitch_gain_is_removed_from_the_force(synthetic):
    """The IMU over-reads a_x by 1 + g·k as the body squats and dives; the features remove it."""
    feats, truth = synthetic
    ok = feats.valid & (np.abs(truth["rho_driven"]) > 0.02)

    def gain(rho: np.ndarray) -> float:
        x = truth["rho_driven"][ok]
        return float(np.polyfit(x, rho[ok], 1)[0])

    assert gain(feats.rho_driven) == pytest.approx(1.0, abs=0.005)
    # Ignoring the pitch (a vehicle file with k = 0) leaves the forces ~2 % high.
    flat = dataclasses.replace(VEHICLE, pitch_gradient_rad_per_mps2=0.0)
    df, _ = synthetic_stream(VEHICLE, duration_s=120.0, rate_hz=100.0, seed=11)
    unaware = compute_features(validate_stream(df, flat), flat)
    assert gain(unaware.rho_driven) == pytest.approx(1.0196, abs=0.005)


def test_traction_split_force_is_continuous_through_zero(synthetic):
    # In traction the two forces agree (rho_driven from the IMU, rho_driven_traction from the
    # wheel speeds' dV_x/dt plus the IMU's grade: the IMU noise apart); under braking rho_driven
    # takes the brake balance (0.7 front) and rho_driven_traction keeps the traction split, so
    # that a window of samples scattered around zero force averages one continuous function.
    feats, _ = synthetic
    total = np.sum(feats.fx_axle_n, axis=1)
    traction = feats.valid & (total > 500.0)
    braking = feats.valid & (total < -500.0)
    difference = feats.rho_driven_traction[traction] - feats.rho_driven[traction]
    assert abs(np.mean(difference)) < 0.005 and np.std(difference) < 0.03
    # Under braking both are negative; the wheels' dV_x/dt there is read off braking reference
    # wheels, which the model never uses (slip windows need the tyres to push).
    assert np.mean(feats.rho_driven_traction[braking] < 0.0) > 0.95


def test_load_change_is_the_driven_axles_load_transfer(synthetic):
    """ΔF_z/F_z,static of the front (driven) axle follows the truth's m (a_x + g sin θ) h/L:
    its acceleration is the traction one (wheels' dV_x/dt plus the IMU's low-passed grade)."""
    feats, truth = synthetic
    ok = feats.valid & np.isfinite(feats.load_change_driven)
    got, true = feats.load_change_driven[ok], truth["front_load_change"][ok]
    assert np.std(true) > 0.02  # the drive moves the load by several percent
    assert float(np.polyfit(true, got, 1)[0]) == pytest.approx(1.0, abs=0.05)
    assert np.median(np.abs(got - true)) < 0.1 * np.std(true)


def test_nuisances_exposed(synthetic):
    feats, truth = synthetic
    nuis = feats.nuisances
    assert nuis.ax_offset_mps2 == pytest.approx(
        truth["ax_offset_mps2"], abs=3 * nuis.ax_offset_sd_mps2 + 0.01
    )
    radius = 1.0 + truth["radius_error"]
    np.testing.assert_allclose(nuis.radius_ratio, radius / radius.mean(), atol=2e-4)
    assert np.all(nuis.radius_ratio_sd < 2e-4)
    np.testing.assert_allclose(
        nuis.quantisation_radps, 0.01 / 3.6 / VEHICLE.wheel_radius_m, rtol=1e-6
    )
    # The reference has no radius error; V_x inherits the rear wheels' one.
    assert nuis.speed_scale == pytest.approx(1 - (truth["radius_error"][2:].mean()), abs=5e-4)
    # Grade kept in ax and estimated: 0.01 rad amplitude recovered to 0.006 rad rms.
    ok = feats.valid
    assert np.sqrt(np.mean((feats.grade_rad[ok] - truth["grade_rad"][ok]) ** 2)) < 0.006


def test_segments_cover_the_drive(synthetic):
    feats, _ = synthetic
    seg = feats.segments()
    assert set(seg) == set(SEGMENT_REGIMES)
    total = sum(v["seconds"] for v in seg.values())
    assert total == pytest.approx(120.0, abs=0.05)
    assert seg["traction"]["seconds"] > 20 and seg["braking"]["seconds"] > 10
    assert seg["high_slip"]["seconds"] == 0.0
    assert np.all(feats.rho_driven[feats.mask("braking")] < 0)


def test_friction_power_is_eq_4_19a(synthetic):
    feats, _ = synthetic
    fx = feats.fx_axle_n[:, 0]
    expected = np.abs(fx * feats.vx_mps * feats.slip_driven)
    np.testing.assert_allclose(feats.friction_power_w, expected)


def test_spin_check_flags_a_spinning_wheel():
    df, _ = synthetic_stream(VEHICLE, duration_s=30.0, rate_hz=50.0, seed=4)
    spin_rows = (df["time"] > 10) & (df["time"] < 11)
    df.loc[spin_rows, "wheel_speed_fl"] *= 1.3  # inner front wheel spins up exiting a bend
    feats = compute_features(validate_stream(df, VEHICLE), VEHICLE)
    assert feats.spin[spin_rows.to_numpy()][5:-5].all()
    assert feats.mask("high_slip")[spin_rows.to_numpy()][5:-5].all()
    assert not feats.spin[(df["time"] > 15).to_numpy()].any()


def test_locked_non_driven_wheel_does_not_drag_vx_down():
    df, truth = synthetic_stream(VEHICLE, duration_s=30.0, rate_hz=50.0, seed=4)
    lock = ((df["time"] > 10) & (df["time"] < 11)).to_numpy()
    df.loc[lock, "wheel_speed_rl"] *= 0.5
    feats = compute_features(validate_stream(df, VEHICLE), VEHICLE)
    inner = np.flatnonzero(lock)[5:-5]
    assert np.all(np.abs(feats.vx_mps[inner] / truth["vx_mps"][inner] - 1) < 0.01)


@pytest.mark.parametrize("drive", ["rwd", "awd"])
def test_other_drives(drive):
    vehicle = dataclasses.replace(VEHICLE, drive=drive)
    df, truth = synthetic_stream(vehicle, duration_s=30.0, rate_hz=50.0, seed=5)
    feats = compute_features(validate_stream(df, vehicle), vehicle)
    assert feats.driven_axle == vehicle.driven_axle
    ok = feats.valid
    assert np.median(np.abs(feats.vx_mps[ok] / truth["vx_mps"][ok] - 1)) < 0.005
    assert np.median(np.abs(feats.rho_driven[ok] - truth["rho_driven"][ok])) < 0.01


def test_curve_compensation_removes_track_width_effect():
    """In a steady turn the inner wheels are slower by ψ̇ t/2; compensated, all agree."""
    df, _ = synthetic_stream(
        VEHICLE,
        duration_s=30.0,
        rate_hz=50.0,
        seed=6,
        wheel_noise_radps=0.0,
        quantise=False,
        radius_error_sd=0.0,
    )
    feats = compute_features(validate_stream(df, VEHICLE), VEHICLE)
    ok = feats.valid & (feats.rho_driven > -0.02) & (feats.rho_driven < 0.02)
    raw_left_right = (df["wheel_speed_rr"] - df["wheel_speed_rl"]).to_numpy()[ok]
    compensated = (feats.wheel_vx_mps[:, 3] - feats.wheel_vx_mps[:, 2])[ok]
    assert np.std(raw_left_right) * VEHICLE.wheel_radius_m > 20 * np.std(compensated)


def test_real_log_vx_matches_gnss(real):
    feats, stream = real
    err = speed_error(feats, stream.data["speed_reference"].to_numpy())
    # The log's wheel speeds were converted with an assumed 0.35 m radius: V_x runs ~1 % low.
    assert abs(err["relative_mean"]) < 0.015
    # After that scale, GNSS (20 Hz, interpolated, lagged) and V_x agree to 0.05 m/s rms.
    assert err["rms_after_scale_mps"] < 0.05
    assert err["samples"] > 5000


def test_real_log_slip_rises_with_force(real):
    feats, _ = real
    ok = feats.valid & ~feats.spin & np.isfinite(feats.rho_driven)
    rho, slip = feats.rho_driven[ok], feats.slip_driven[ok]
    assert np.corrcoef(rho, slip)[0, 1] > 0.6
    slope = np.polyfit(rho, slip, 1)[0]
    assert 1 / 80 < slope < 1 / 15  # C_x between 15 and 80: passenger-car tyres
    hard = slip[rho > 0.15].mean()
    soft = slip[np.abs(rho) < 0.02].mean()
    assert hard > soft + 0.002


def test_real_log_nuisances(real):
    feats, _ = real
    nuis = feats.nuisances
    # Data README: mean ax about -0.57 m/s² on a near-flat road (dashcam pitch).
    assert -0.8 < nuis.ax_offset_mps2 < -0.4
    np.testing.assert_allclose(nuis.quantisation_radps, 0.01 / 3.6 / 0.35, rtol=1e-3)
    assert np.all(np.abs(nuis.radius_ratio - 1) < 0.005)
    # The dashcam reads a_x low (0.79 against GNSS as a plain slope, real_vs_sim.py): the
    # band-passed estimate must see it below a calibrated IMU's and pass the doubt on.
    gain = nuis.ax_gain
    assert gain.estimate + 2 * gain.estimate_sd < 1.0
    assert 0.3 < gain.p_uncalibrated < 0.9 and gain.applied < 0.97 and gain.applied_log_sd > 0.03


def test_a_known_imu_gain_is_divided_out_and_a_bad_one_rejected(synthetic):
    feats, _ = synthetic
    stream = validate_stream(synthetic_stream(VEHICLE, duration_s=120.0, rate_hz=100.0, seed=11)[0])
    halved = dataclasses.replace(stream, data=stream.data.assign(ax=stream.data["ax"] * 0.5))
    known = compute_features(halved, VEHICLE, ax_gain=0.5)
    assert known.nuisances.ax_gain.applied == 0.5 and known.nuisances.ax_gain.uncalibrated
    ok = feats.valid & known.valid
    np.testing.assert_allclose(known.rho_driven[ok], feats.rho_driven[ok], atol=2e-3)
    with pytest.raises(ValueError, match="ax_gain: expected a value > 0, got -1"):
        compute_features(stream, VEHICLE, ax_gain=-1.0)


def test_steered_wheels_read_with_the_turns_sideslip():
    """A tight turn at walking pace: the front wheels' speed carries the body's sideslip
    (ψ̇ l_r sin δ), which eq. 4.23's β = 0 would read as 1-2 % of slip."""
    from tyrebayes.streams.motion import REAR_CORNERING_PER_RAD, _front_terms, _wheel_to_vx

    vx = np.array([3.0, 4.0, 6.0, 25.0])
    steer = np.array([0.18, 0.15, 0.10, 0.004])  # road-wheel angle [rad]
    length, lr = VEHICLE.wheelbase_m, VEHICLE.cog_to_rear_axle_m
    yaw = vx * np.tan(steer) / length
    ay = vx * yaw
    rear_slip_angle = ay / (9.80665 * REAR_CORNERING_PER_RAD)
    vy = yaw * lr - vx * rear_slip_angle
    half, lf = 0.5 * VEHICLE.track_width_m, VEHICLE.cog_to_front_axle_m
    y = np.array([half, -half, half, -half])
    u = vx[:, None] - yaw[:, None] * y[None, :]
    u[:, :2] = u[:, :2] * np.cos(steer)[:, None] + ((vy + yaw * lf) * np.sin(steer))[:, None]
    omega = u / VEHICLE.wheel_radius_m
    got = _wheel_to_vx(omega, yaw, VEHICLE, _front_terms(yaw, steer, ay, VEHICLE))
    # Within 1e-4 of slip at every speed; the β = 0 reading is off by ≥ 1 % at 3-4 m/s.
    assert np.max(np.abs(got / vx[:, None] - 1.0)) < 1e-4
    beta_zero = (u[:, 0] - yaw * lf * np.sin(steer)) / np.cos(steer) + yaw * half
    assert np.all(np.abs(beta_zero[:2] / vx[:2] - 1.0) > 0.01)


def test_mask_refuses_the_old_keyword_naming_regime(synthetic):
    feats, _ = synthetic
    assert np.array_equal(feats.mask(regime="braking"), feats.mask("braking"))
    with pytest.raises(TypeError, match="mask: keyword 'kind' is now 'regime'"):
        feats.mask(kind="braking")
