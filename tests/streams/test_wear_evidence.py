"""Per-drive wear evidence: its row, and the radius ratio recovering a set radius change."""

import equinox as eqx
import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.simulate.sensors import SensorModel, draw_sensor_truth
from tyrebayes.streams import validate_stream
from tyrebayes.streams.wear_evidence import WEAR_EVIDENCE_COLUMNS, drive_wear_evidence

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


def test_each_axle_has_its_own_tyre_temperature():
    """A front-driven commute: the free rear tyres run cooler than the driven front ones; each
    axle's friction-power weighted temperature is the simulator's within 1.5 K, and the rolling
    radius behind the ratio's mm scale is the car's."""
    from tyrebayes.simulate.wear_history import COMMUTE_PROFILE, lateral_sliding_power

    df, truth = simulate_drive(
        3, VEHICLE, "summer", duration_s=600.0, sample_rate_hz=10.0, profile=COMMUTE_PROFILE
    )
    ev = drive_wear_evidence(validate_stream(df, VEHICLE), VEHICLE)
    power = np.abs(truth.rho_x * truth.wheel_load_n * truth.wheel_centre_speed_mps * truth.slip)
    power = power + np.repeat(lateral_sliding_power(truth, VEHICLE) / 2.0, 2, axis=1)
    temp = truth.tyre_temperature_c
    true = [
        np.sum(temp[:, s] * power[:, s]) / np.sum(power[:, s]) for s in (slice(0, 2), slice(2, 4))
    ]
    assert ev.tyre_temperature_axle_c == pytest.approx(true, abs=1.5)
    assert ev.tyre_temperature_axle_c[1] < ev.tyre_temperature_axle_c[0] - 1.0
    row = ev.row()
    assert row["rolling_radius_mm"] == pytest.approx(1000.0 * VEHICLE.wheel_radius_m)
    assert row["tyre_temperature_rear_c"] == ev.tyre_temperature_axle_c[1]
