"""Per-drive wear evidence: friction work against a hand computation, radius ratio recovery."""

import equinox as eqx
import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.simulate.sensors import SensorModel, draw_sensor_truth
from tyrebayes.streams import compute_features, validate_stream
from tyrebayes.streams.wear_evidence import (
    WEAR_EVIDENCE_COLUMNS,
    _corrected_slip,
    _free_slip_ratios,
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
    fx, fz, v = feats.fx_axle_n[:, 0], feats.fz_axle_n[:, 0], feats.vx_mps
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
