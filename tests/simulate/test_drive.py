"""Tests of the drive simulator: physics identities against the truth, sensors, events, I/O."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.physics.thermal import StiffnessTemperature, stiffness_at_temperature
from tyrebayes.physics.tyre import (
    MagicFormulaLongitudinal,
    brush_longitudinal,
    brush_longitudinal_inverse,
    magic_formula_longitudinal,
)
from tyrebayes.physics.vehicle import (
    GRAVITY_MPS2,
    aero_drag,
    rolling_resistance_force,
    wheel_loads,
)
from tyrebayes.simulate.drive import drawn_curve, simulate_drive, wheel_loads_np
from tyrebayes.simulate.drive_io import read_drive_truth, truth_paths, write_drive
from tyrebayes.simulate.profiles import LONG_LABELS, ProfileOptions
from tyrebayes.simulate.sensors import SensorModel
from tyrebayes.simulate.tyre_curves import (
    brush_force_np,
    brush_inverse_np,
    peak_slip,
    tyre_force,
    tyre_slip,
)
from tyrebayes.simulate.tyre_set import simulate_tyre_set_drives
from tyrebayes.simulate.tyre_spec import TyreSpec
from tyrebayes.streams.schema import REQUIRED_COLUMNS

# One duration for most drives so the thermal scan compiles once per test session.
DUR = 120.0
ABS_OPTS = ProfileOptions(n_abs_events=2, hard_brakes_per_hour=0.0)


@pytest.fixture(scope="module")
def ideal_abs_drive():
    return simulate_drive(
        7,
        "suv_rav4",
        "summer",
        duration_s=DUR,
        ambient_c=5.0,
        profile=ABS_OPTS,
        sensor=SensorModel.ideal(),
        # The brush truth is flat beyond its peak: the ABS tests read μ off it exactly.
        tyre_model="brush",
    )


@pytest.fixture(scope="module")
def noisy_drive():
    return simulate_drive(
        11, "compact_fwd", "winter", duration_s=DUR, surface="snow", ambient_c=-5.0
    )


def test_numpy_twins_match_physics():
    """The simulator's NumPy hot path is the physics module's formulas (x64, 1e-12)."""
    rng = np.random.default_rng(0)
    slip = rng.uniform(-0.4, 0.4, 200)
    for ratio in (1.0, 0.7):
        np.testing.assert_allclose(
            brush_force_np(slip, 33.0, 0.8, ratio),
            np.asarray(brush_longitudinal(jnp.asarray(slip), 33.0, 0.8, ratio)),
            rtol=0,
            atol=1e-12,
        )
    rho = rng.uniform(-0.79, 0.79, 200)
    np.testing.assert_allclose(
        brush_inverse_np(rho, 33.0, 0.8),
        np.asarray(brush_longitudinal_inverse(jnp.asarray(rho), 33.0, 0.8)),
        rtol=0,
        atol=1e-12,
    )
    veh = load_vehicle("compact_fwd")
    ax, ay = rng.normal(0, 3, 50), rng.normal(0, 3, 50)
    np.testing.assert_allclose(
        wheel_loads_np(veh, ax, ay),
        np.asarray(wheel_loads(veh, jnp.asarray(ax), jnp.asarray(ay))),
        rtol=1e-12,
    )


def test_magic_formula_truth_is_the_measured_curve_when_unscaled():
    """With C_x = PKX1 and μ = PDX1 at fz0 = FNOMIN the scaled MF is the measured one."""
    mf = MagicFormulaLongitudinal.from_measured("pacejka_205_60R15")
    spec = TyreSpec.from_type("summer")
    slip = np.linspace(-0.5, 0.5, 101)
    fz = np.full_like(slip, 5200.0)
    np.testing.assert_allclose(
        tyre_force("magic_formula", slip, fz, mf.pkx1, mf.pdx1, spec, mf.fnomin_n),
        np.asarray(magic_formula_longitudinal(jnp.asarray(slip), jnp.asarray(fz), mf)),
        atol=1e-12,
    )


@pytest.mark.parametrize("model", ["brush", "magic_formula"])
def test_tyre_curve_inverse_and_peak(model):
    spec = TyreSpec.from_type("all_season")
    fz = np.linspace(2500.0, 6500.0, 50)
    rho = np.linspace(-0.9, 0.9, 50)
    slip, ok = tyre_slip(model, rho, fz, 40.0, 1.0, spec, 4500.0)
    assert ok.all()
    np.testing.assert_allclose(tyre_force(model, slip, fz, 40.0, 1.0, spec, 4500.0), rho, atol=1e-9)
    # Slope C_x at zero slip (at the nominal load) and peak μ at the peak slip.
    h = 1e-7
    slope = tyre_force(model, np.array([h]), 4500.0, 40.0, 1.0, spec, 4500.0)[0] / h
    assert slope == pytest.approx(40.0, rel=1e-5)
    s_pk = peak_slip(model, np.array([4500.0]), 40.0, 1.0, spec, 4500.0)
    assert tyre_force(model, s_pk, 4500.0, 40.0, 1.0, spec, 4500.0)[0] == pytest.approx(
        1.0, abs=1e-9
    )
    # Demands beyond 97 % of the peak are clipped and reported.
    _, ok = tyre_slip(model, np.array([0.99]), 4500.0, 40.0, 1.0, spec, 4500.0)
    assert not ok[0]


def test_stream_contract_and_shapes(noisy_drive):
    df, truth = noisy_drive
    for col in REQUIRED_COLUMNS + ("az", "speed_reference", "ambient_temperature"):
        assert col in df.columns
    assert len(df) == truth.n_samples == int(DUR * 100)
    assert np.all(np.diff(df["time"].to_numpy()) > 0)
    assert truth.slip.shape == truth.rho_x.shape == (len(df), 4)
    assert truth.surface == "snow" and truth.mu_max == pytest.approx(0.45)
    assert np.isfinite(truth.samples().to_numpy(dtype=float)).all()


@pytest.mark.parametrize("rate_hz", [10.0, 100.0])
def test_lateral_motion_is_single_track_kinematics(rate_hz):
    """The logged a_y is V ψ̇ + v̇_y of the truth's own v_y, and the rear axle's slip angle
    (l_r ψ̇ − v_y)/V carries the force of that acceleration on the brush curve: the lateral
    model's two equations hold on the simulator's truth, at a log's rates."""
    car = load_vehicle("compact_fwd")
    _, tr = simulate_drive(5, car, "summer", duration_s=300.0, sample_rate_hz=rate_hz)
    moving = tr.vx_mps > 2.0
    dt = 1.0 / rate_hz  # the simulator's clock (the logged stamps carry jitter)
    vy_dot = np.gradient(tr.vy_mps, dt)
    kinematic = tr.vx_mps * tr.yaw_rate_radps + vy_dot
    assert np.abs(tr.ay_mps2).max() > 1.0
    # the gradient's discretisation error only: a few hundredths of a m/s², where v̇_y is tenths
    assert np.percentile(np.abs(tr.ay_mps2 - kinematic)[moving], 99) < 0.03
    assert np.abs(vy_dot[moving]).max() > 0.1
    tan_r = (car.cog_to_rear_axle_m * tr.yaw_rate_radps - tr.vy_mps) / np.maximum(tr.vx_mps, 1.0)
    rear = (
        car.mass_kg * tr.ay_mps2 * car.cog_to_front_axle_m
        - car.yaw_inertia_kgm2 * np.gradient(tr.yaw_rate_radps, dt)
    ) / car.wheelbase_m
    rho = rear / tr.wheel_load_n[:, 2:].sum(axis=1)
    np.testing.assert_allclose(
        rho[moving], brush_force_np(tan_r, tr.c_y_per_rad, tr.mu_max)[moving], atol=2e-3
    )


@pytest.mark.parametrize("model", ["brush", "magic_formula"])
def test_truth_is_self_consistent(model):
    """ρ_x(σ_x) of the truth curve, wheel speeds from slip and radius, force balance, C_x(T)."""
    veh = load_vehicle("suv_rav4")
    spec = TyreSpec.from_type("summer")
    df, tr = simulate_drive(
        3,
        veh,
        spec,
        duration_s=DUR,
        ambient_c=5.0,
        profile=ABS_OPTS,
        tyre_model=model,
        sensor=SensorModel.ideal(),
    )
    # Every wheel's force is the truth curve at its slip, ABS samples included.
    rho = tyre_force(
        model, tr.slip, tr.wheel_load_n, tr.c_x_wheel, tr.mu_max, spec, tr.fz_static_n[None, :]
    )
    moving = tr.vx_mps > 0.5
    np.testing.assert_allclose(rho[moving], tr.rho_x[moving], atol=1e-9)
    # Ideal sensors: Ω = v_wheel (1 + σ)/R exactly (no quantisation, noise or dropouts).
    omega = tr.wheel_centre_speed_mps * (1 + tr.slip) / tr.radius_m[None, :]
    wheels = df[["wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl", "wheel_speed_rr"]].to_numpy()
    np.testing.assert_allclose(wheels, omega, atol=1e-9)
    # Longitudinal balance on straight road: F_x,front + F_x,rear = m a_x + drag + rolling + grade.
    straight = moving & (np.abs(tr.road_wheel_angle_rad) < 1e-3)
    resist = (
        np.asarray(aero_drag(veh, tr.vx_mps))
        + np.asarray(rolling_resistance_force(veh, tr.grade_rad))
        + veh.mass_kg * GRAVITY_MPS2 * np.sin(tr.grade_rad)
    )
    lhs = tr.fx_front_n + tr.fx_rear_n
    rhs = veh.mass_kg * tr.ax_mps2 + resist
    # 1 N: ABS samples are a fixed point over load transfer (6 iterations), the rest is exact.
    np.testing.assert_allclose(lhs[straight], rhs[straight], atol=1.0)
    # Stiffness follows the tyre temperature through StiffnessTemperature.
    comp = StiffnessTemperature()
    np.testing.assert_allclose(
        tr.c_x_wheel[::500],
        np.asarray(
            stiffness_at_temperature(tr.c_xr, jnp.asarray(tr.tyre_temperature_c[::500]), comp)
        ),
        rtol=1e-10,
    )
    # Ideal IMU: specific force a_x + g sin(grade), gravity included, in the body frame pitched
    # by the vehicle's squat/dive k·a_x.
    pitch = veh.pitch_gradient_rad_per_mps2 * tr.ax_mps2
    specific = tr.ax_mps2 + GRAVITY_MPS2 * np.sin(tr.grade_rad)
    vertical = GRAVITY_MPS2 * np.cos(tr.grade_rad)
    np.testing.assert_allclose(
        df["ax"].to_numpy(), specific * np.cos(pitch) + vertical * np.sin(pitch), atol=1e-9
    )


def test_abs_events_reach_the_peak(ideal_abs_drive):
    """ABS cycles slip around the peak: μ_max is reached and the deceleration is about μ g."""
    df, tr = ideal_abs_drive
    m = tr.abs_mask
    assert m.sum() > 100
    steady = m & (np.abs(tr.slip[:, 0]) > 0.5 * tr.abs_peak_slip)
    # The brush truth is flat beyond the peak: wheels above peak slip deliver exactly μ.
    above = m[:, None] & (np.abs(tr.slip) >= 3 * tr.mu_max / tr.c_x_wheel)
    assert above.sum() > 50
    np.testing.assert_allclose(np.abs(tr.rho_x[above]), tr.mu_max, rtol=1e-9)
    # The slip range spans the peak on both sides (0.5-1.5 times the peak slip).
    rel = np.abs(tr.slip[m]) / (3 * tr.mu_max / tr.c_x_wheel[m])
    assert rel.min() < 0.7 and rel.max() > 1.3
    # Mean deceleration within 15 % of μ g (cycling below the peak loses some).
    decel = -tr.ax_mps2[steady].mean()
    assert 0.8 * tr.mu_max * GRAVITY_MPS2 < decel < 1.05 * tr.mu_max * GRAVITY_MPS2
    # Outside ABS the demand never exceeded the tyres.
    assert not tr.force_clipped.any()


def test_temperature_and_stiffness_evolve(noisy_drive):
    _, tr = noisy_drive
    assert tr.tyre_temperature_c[0, 0] == pytest.approx(-5.0)
    # Rolling losses warm the tyres, so C_x falls below its value at ambient.
    assert tr.tyre_temperature_c[-1].mean() > -5.0 + 0.5
    assert np.all(np.diff(tr.c_x) <= 1e-9) or tr.c_x[-1] < tr.c_x[0]


def test_sensor_model_resembles_real_log(noisy_drive):
    """Default quantisation equals the real log's 0.01 km/h step; offsets are drawn and recorded."""
    df, tr = noisy_drive
    veh = load_vehicle("compact_fwd")
    step = 0.01 / 3.6 / veh.wheel_radius_m
    assert tr.wheel_speed_step_radps == pytest.approx(step)
    w = df["wheel_speed_fl"].dropna().to_numpy()
    k = w / step
    assert np.max(np.abs(k - np.round(k))) < 1e-6
    assert np.all(np.abs(tr.radius_error) < 0.01)
    np.testing.assert_allclose(tr.slip_offset, 1 / (1 + tr.radius_error) - 1)
    # Dropped samples: about 0.1 % per channel plus bursts; time is never NaN.
    nan_frac = df["ax"].isna().mean()
    assert 0.0 < nan_frac < 0.02
    assert not df["time"].isna().any()
    # GNSS is held at 20 Hz: runs of ~5 equal values at 100 Hz.
    ref = df["speed_reference"].dropna().to_numpy()
    assert 0.15 < np.mean(np.diff(ref) != 0) < 0.25


def test_drawn_curve_is_the_curve_a_tyre_type_gets():
    """A benchmark that changes the drawn curve (tyre_recovery.py) simulates the same drive."""
    by_type, _ = simulate_drive(7, "compact_fwd", "winter", duration_s=DUR)
    spec = TyreSpec.from_type("winter", magic_formula=drawn_curve(7))
    given, _ = simulate_drive(7, "compact_fwd", spec, duration_s=DUR)
    np.testing.assert_array_equal(by_type.to_numpy(), given.to_numpy())


def test_seed_streams_are_independent():
    """The same seed gives the same drive; another sensor model leaves the route unchanged."""
    a_df, a = simulate_drive(5, "compact_fwd", "summer", duration_s=DUR)
    b_df, b = simulate_drive(5, "compact_fwd", "summer", duration_s=DUR)
    c_df, c = simulate_drive(5, "compact_fwd", "summer", duration_s=DUR, sensor=SensorModel.ideal())
    np.testing.assert_array_equal(a_df.to_numpy(), b_df.to_numpy())
    np.testing.assert_array_equal(a.vx_mps, c.vx_mps)
    _, d = simulate_drive(jax.random.key(5), "compact_fwd", "summer", duration_s=DUR)
    assert not np.array_equal(a.vx_mps, d.vx_mps)


def test_low_friction_surface_limits_the_driver():
    """On ice the driver stays within the tyres' reach: no clipped demand, |ρ| < μ."""
    _, tr = simulate_drive(
        2, "compact_fwd", "winter", duration_s=DUR, surface="ice", ambient_c=-8.0
    )
    assert not tr.force_clipped.any()
    assert np.abs(tr.rho_x).max() < tr.mu_max


def test_rate_and_jitter():
    df, tr = simulate_drive(
        4,
        "suv_rav4",
        "summer",
        duration_s=60.0,
        sample_rate_hz=83.0,
        sensor=SensorModel.rav4_comma2k19(),
    )
    dt = np.diff(df["time"].to_numpy())
    assert np.all(dt > 0)
    assert np.median(dt) == pytest.approx(1 / 83.0, rel=0.05)
    assert 0.15 < dt.std() / dt.mean() < 0.5
    assert tr.mounting_pitch_rad == pytest.approx(np.deg2rad(-4.6))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"surface": "gravel"}, "surface"),
        ({"tyre_model": "fiala"}, "tyre_model"),
        ({"duration_s": -1.0}, "duration_s"),
        ({"sample_rate_hz": 5.0}, "sample_rate_hz"),
        ({"ambient_c": 99.0}, "ambient_c"),
    ],
)
def test_bad_inputs_raise(kwargs, match):
    args = {"duration_s": 10.0} | kwargs
    with pytest.raises(ValueError, match=match):
        simulate_drive(0, "compact_fwd", "summer", **args)


def test_bad_options_raise():
    with pytest.raises(ValueError, match="timing_jitter"):
        SensorModel(timing_jitter=0.6)
    with pytest.raises(ValueError, match="cruise_weights"):
        ProfileOptions(cruise_weights=(1.0,))
    with pytest.raises(ValueError, match="c_xr"):
        TyreSpec(c_xr=-1.0, mu_dry=1.0, mu_wet=0.8, mu_snow=0.3, mu_ice=0.1)
    with pytest.raises(ValueError, match="tyre_type"):
        simulate_drive(0, "compact_fwd", "touring", duration_s=10.0)
    with pytest.raises(ValueError, match="vehicle"):
        simulate_drive(0, "no_such_car", "summer", duration_s=10.0)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_write_drive_round_trip(tmp_path, noisy_drive, suffix):
    df, tr = noisy_drive
    path = tmp_path / f"drive{suffix}"
    files = write_drive(df, tr, path)
    assert files["stream"].is_file() and truth_paths(path)[0].is_file()
    back = read_drive_truth(path)
    assert back.c_xr == tr.c_xr and back.surface == tr.surface
    np.testing.assert_array_equal(back.slip, tr.slip)
    np.testing.assert_array_equal(back.long_label, tr.long_label)
    assert not list(tmp_path.glob(".*tmp*"))  # no temporary files left behind


def test_tyre_set_drives_share_the_tyre_and_car():
    drives = simulate_tyre_set_drives(
        1, "compact_fwd", "winter", n_drives=3, duration_s=30.0, surfaces=("snow", "wet", "dry")
    )
    truths = [t for _, t in drives]
    assert {t.c_xr for t in truths} == {30.0}
    assert [t.surface for t in truths] == ["snow", "wet", "dry"]
    assert truths[0].mu_max < truths[1].mu_max < truths[2].mu_max
    assert truths[0].ambient_c <= 0.0
    radius = np.stack([t.radius_error for t in truths])
    assert np.abs(radius - radius.mean(0)).max() < 0.003  # one car, small daily drift
    assert len({t.mounting_pitch_rad for t in truths}) == 1


def test_abs_label_code():
    assert LONG_LABELS.index("abs") == 5


@pytest.mark.parametrize("drive", ["rwd", "awd"])
def test_other_drivetrains(drive):
    """Traction goes to the driven axle(s): free-rolling wheels carry no force outside braking."""
    import dataclasses

    veh = dataclasses.replace(load_vehicle("suv_rav4"), drive=drive)
    _, tr = simulate_drive(
        1,
        veh,
        "summer",
        duration_s=DUR,
        sensor=SensorModel.ideal(),
        profile=ProfileOptions(hard_brakes_per_hour=0.0),
    )
    assert tr.drive == drive
    traction = tr.fx_front_n + tr.fx_rear_n > 0
    if drive == "rwd":
        np.testing.assert_allclose(tr.rho_x[traction][:, :2], 0.0, atol=1e-12)
        assert np.all(tr.rho_x[traction][:, 2:] > 0)
    else:
        share = veh.front_drive_fraction
        front = tr.fx_front_n[traction] / np.cos(tr.road_wheel_angle_rad[traction])
        np.testing.assert_allclose(front, share * (front + tr.fx_rear_n[traction]), rtol=1e-9)
    assert not tr.force_clipped.any()
