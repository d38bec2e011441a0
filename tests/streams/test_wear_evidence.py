"""Per-drive wear evidence: friction work against a hand computation, radius ratio recovery."""

import equinox as eqx
import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.physics.vehicle import GRAVITY_MPS2
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.simulate.sensors import SensorModel, draw_sensor_truth
from tyrebayes.simulate.wear_history import COMMUTE_PROFILE, lateral_sliding_power
from tyrebayes.streams import compute_features, validate_stream
from tyrebayes.streams.wear_evidence import (
    ENGINE_BRAKE_SHARE,
    TYPE_PRIOR_CORNERING,
    WEAR_EVIDENCE_COLUMNS,
    CorneringStiffness,
    _corrected_slip,
    _free_slip_ratios,
    braking_split,
    brush_slip_angle,
    drive_wear_evidence,
)

VEHICLE = load_vehicle("compact_fwd")


def _drive(seed, radius_error=None, duration_s=180.0):
    rng = np.random.default_rng(seed)
    offsets = draw_sensor_truth(rng, SensorModel(), VEHICLE.wheel_radius_m)
    if radius_error is not None:
        offsets = eqx.tree_at(lambda s: s.radius_error, offsets, np.asarray(radius_error))
    df, truth = simulate_drive(
        seed,
        VEHICLE,
        "summer",
        duration_s=duration_s,
        sample_rate_hz=10.0,
        ambient_c=12.0,
        sensor_offsets=offsets,
    )
    return validate_stream(df, VEHICLE), truth


@pytest.fixture(scope="module")
def drive():
    return _drive(3)


def test_row_has_the_listed_columns(drive):
    ev = drive_wear_evidence(drive[0], VEHICLE)
    row = ev.row()
    assert tuple(row) == WEAR_EVIDENCE_COLUMNS
    assert all(isinstance(v, float) for v in row.values())
    assert np.isnan(row["odometer_start_km"])  # no odometer column in this stream
    assert row["ambient_c"] == pytest.approx(12.0, abs=0.5)


def test_friction_work_against_a_hand_computation(drive):
    """W_x of the driven axle = Σ F_x V σ_x dt (traction, eq. 4.19a) + Σ ρ² F_z V dt / Ĉ_x."""
    stream, truth = drive
    feats = compute_features(stream, VEHICLE)
    ev = drive_wear_evidence(stream, VEHICLE, features=feats)
    dt = 1.0 / feats.sample_rate_hz
    c_hat = ev.secant_stiffness
    slip = _corrected_slip(feats, _free_slip_ratios(feats, [0], c_hat), "fwd")
    sigma = slip[:, :2].mean(axis=1)
    fx = braking_split(feats.fx_axle_n, feats.fz_axle_n, VEHICLE)[:, 0]
    fz, v = feats.fz_axle_n[:, 0], feats.vx_mps
    ok = feats.valid & np.isfinite(fx) & np.isfinite(sigma) & ~feats.spin
    pull = ok & (fx > 0)
    hand = np.sum(fx[pull] * v[pull] * sigma[pull]) * dt
    rest = ok & ~(fx > 0)
    hand += np.sum((fx[rest] / fz[rest]) ** 2 * fz[rest] * v[rest]) * dt / c_hat
    assert ev.work_x_j[0] == pytest.approx(hand, rel=1e-9)
    # and the secant stiffness is the traction kernel over the measured traction work
    kernel = np.sum((fx[pull] / fz[pull]) ** 2 * fz[pull] * v[pull]) * dt
    measured = np.sum(fx[pull] * v[pull] * sigma[pull]) * dt
    assert c_hat == pytest.approx(kernel / measured, rel=1e-9)
    # physics: a front-driven car's front tyres do most of the work; the scale is the
    # simulator's within the stated evidence error (benchmarks/results/wear_history.json)
    true = np.sum(
        np.abs(truth.rho_x * truth.wheel_load_n * truth.wheel_centre_speed_mps * truth.slip), axis=0
    ) * np.mean(np.diff(truth.time_s))
    assert ev.work_x_j[0] > 5 * ev.work_x_j[1]
    assert 0.5 < ev.work_x_j[0] / true[:2].sum() < 1.5
    assert 0 < ev.work_x_sd_j[0] < 0.2 * ev.work_x_j[0]


def test_radius_ratio_recovers_a_set_radius_change():
    """Front tyres 1 mm smaller (0.32 % of the radius): the ratio falls by that much."""
    base = np.array([0.001, -0.001, 0.0005, 0.0])
    worn = base - np.array([1.0, 1.0, 0.0, 0.0]) / (1000.0 * VEHICLE.wheel_radius_m)
    a = drive_wear_evidence(_drive(5, base)[0], VEHICLE)
    b = drive_wear_evidence(_drive(5, worn)[0], VEHICLE)
    expected = (1 + worn[:2].mean()) / (1 + worn[2:].mean()) - (1 + base[:2].mean()) / (
        1 + base[2:].mean()
    )
    change = b.radius_ratio_front_rear - a.radius_ratio_front_rear
    sd = np.hypot(a.radius_ratio_front_rear_sd, b.radius_ratio_front_rear_sd)
    assert change == pytest.approx(expected, abs=max(4 * sd, 1e-4))
    assert abs(change - expected) < 0.1 * abs(expected)


def test_braking_split_puts_engine_drag_on_the_driven_axle():
    weight = VEHICLE.mass_kg * GRAVITY_MPS2
    fz = np.array([[8000.0, 6000.0]] * 3)
    coast = -0.5 * ENGINE_BRAKE_SHARE * weight
    hard = -0.5 * weight
    fx = np.array([[0.7 * coast, 0.3 * coast], [0.7 * hard, 0.3 * hard], [900.0, 0.0]])
    out = braking_split(fx, fz, VEHICLE)
    assert out.sum(axis=1) == pytest.approx(fx.sum(axis=1))  # the total is kept
    assert out[0] == pytest.approx([coast, 0.0])  # coasting: engine drag on the driven front
    engine = -ENGINE_BRAKE_SHARE * weight
    assert out[1, 0] == pytest.approx(engine + (hard - engine) * 8000.0 / 14000.0)
    assert out[2] == pytest.approx(fx[2])  # traction as it was


def test_brush_slip_angle_is_linear_for_small_forces_and_steeper_near_the_peak():
    rho = np.array([1e-3, 0.5, 0.9])
    t = brush_slip_angle(rho, 20.0, mu=1.0)
    assert t[0] == pytest.approx(1e-3 / 20.0, rel=1e-3)
    assert t[1] > 0.5 / 20.0 and t[2] / t[1] > 0.9 / 0.5
    # W_y ∝ 1 / c_y exactly: the stiffness only scales the slip angle
    assert brush_slip_angle(rho, 10.0) == pytest.approx(2.0 * brush_slip_angle(rho, 20.0))


@pytest.fixture(scope="module")
def cornering_drive():
    df, truth = simulate_drive(
        7, VEHICLE, "summer", duration_s=240.0, sample_rate_hz=10.0, profile=COMMUTE_PROFILE
    )
    return validate_stream(df, VEHICLE), truth


def test_lateral_work_uses_the_given_stiffness(cornering_drive):
    """W_y = Σ |F_y V tan α| dt with α from the given per-axle c_y (eq. 4.19b, 4.23b, c)."""
    stream, truth = cornering_drive
    feats = compute_features(stream, VEHICLE)
    given = CorneringStiffness(truth.c_y_per_rad, 2.0 * truth.c_y_per_rad, 0.1, "lateral_fit")
    ev = drive_wear_evidence(stream, VEHICLE, features=feats, cornering=given)
    assert ev.cornering.source == "lateral_fit"
    assert ev.row()["cornering_stiffness_rear_per_rad"] == 2.0 * truth.c_y_per_rad
    dt = 1.0 / feats.sample_rate_hz
    v = feats.vx_mps
    ay, yaw_acc = v * feats.yaw_rate_radps, feats.yaw_acc_radps2
    lf, wb = VEHICLE.cog_to_front_axle_m, VEHICLE.wheelbase_m
    fy_f = (VEHICLE.mass_kg * ay * (wb - lf) + VEHICLE.yaw_inertia_kgm2 * yaw_acc) / wb
    ok = feats.valid & np.isfinite(fy_f)
    alpha = brush_slip_angle(fy_f[ok] / feats.fz_axle_n[ok, 0], truth.c_y_per_rad)
    hand = np.sum(np.abs(fy_f[ok] * v[ok] * alpha)) * dt
    assert ev.work_y_j[0] == pytest.approx(hand, rel=1e-9)
    # the type prior (16.5 /rad, softer) reads more lateral work; a stiffer rear reads less
    prior = drive_wear_evidence(stream, VEHICLE, features=feats)
    assert prior.cornering.source == "type_prior"
    assert prior.work_y_j[0] == pytest.approx(
        ev.work_y_j[0] * truth.c_y_per_rad / TYPE_PRIOR_CORNERING.front_per_rad, rel=1e-9
    )
    assert prior.work_y_j[1] == pytest.approx(
        ev.work_y_j[1] * 2.0 * truth.c_y_per_rad / TYPE_PRIOR_CORNERING.rear_per_rad, rel=1e-9
    )
    # with the true c_y the evidence reads the simulator's true lateral work (eq. 4.19b)
    true = np.sum(lateral_sliding_power(truth, VEHICLE), axis=0) * dt
    right = drive_wear_evidence(
        stream,
        VEHICLE,
        features=feats,
        cornering=CorneringStiffness(truth.c_y_per_rad, truth.c_y_per_rad, 0.0),
    )
    assert right.work_y_j == pytest.approx(true, rel=0.15)
    with pytest.raises(ValueError, match="front_per_rad: expected > 0"):
        CorneringStiffness(0.0, 20.0, 0.1)
