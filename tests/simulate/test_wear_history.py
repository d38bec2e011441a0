"""A simulated year of wearing tyres: files with an odometer, radii that shrink, tyre changes."""

import numpy as np
import pytest

from tyrebayes.simulate.wear_history import lateral_sliding_power, simulate_wear_year
from tyrebayes.streams import read_stream


@pytest.fixture(scope="module")
def year(tmp_path_factory):
    folder = tmp_path_factory.mktemp("year")
    return simulate_wear_year(
        2,
        folder,
        n_drives=6,
        drive_s=60.0,
        km_per_year=3000.0,
        rotation_at=0.5,
        replacement_at=None,
        reading_every_km=1000.0,
    )


def test_files_carry_an_odometer_that_grows(year):
    starts = []
    for path in year.stream_paths:
        df = read_stream(path)
        odo = df["odometer"].to_numpy()
        assert np.all(np.diff(odo) >= 0)
        starts.append(odo[0])
    assert np.all(np.diff(starts) > 300e3)  # each drive stands for ~500 km
    assert year.total_km == pytest.approx(3000.0, rel=0.5)


def test_tread_wears_and_the_rotation_swaps_axles(year):
    d = year.depth_mm
    assert year.change_drive_index == (3,) and year.change_type == ("rotation",)
    # before the rotation the driven front tyres lose more than the rear ones
    assert (d[0, :2] - d[2, :2]).min() > (d[0, 2:] - d[2, 2:]).max()
    # at the rotation the front tyres go to the rear (same side)
    assert np.all(d[3, 2:] <= d[2, :2]) and np.all(d[3, :2] <= d[2, 2:])
    assert np.all(d[2, :2] - d[3, 2:] > d[2, 2:] - d[3, :2])  # still driven hardest: the front
    assert d[3, 2:].mean() < d[3, :2].mean()
    assert np.all(year.drive_work_j[:, 0] > 0) and np.all(year.drive_work_j >= 0)
    assert set(year.readings["axle"]) == {"front", "rear"}


def test_the_truth_wears_by_lateral_work_too(year):
    """Drives corner: the truth carries lateral sliding work (eq. 4.19b), and the free-rolling
    rear axle of the front-driven car wears almost only by it."""
    wx, wy = year.drive_work_j.sum(axis=0), year.drive_work_y_j.sum(axis=0)
    assert np.all(year.drive_work_y_j >= 0) and wy.sum() > 0
    assert wy[1] > 5 * wx[1]  # rear: lateral work dominates
    assert 0.1 < wy.sum() / (wx.sum() + wy.sum()) < 0.9
    rate = year.wear_mm_per_1000km
    assert rate[0] > rate[1] > 0
    # the axles' lost tread adds up to the depths the tyres show at the end of the first set
    before = year.depth_mm[0] - year.depth_mm[2]
    assert year.interval_loss_mm[:2, 0].sum() == pytest.approx(before[:2].mean(), rel=1e-9)
    assert year.interval_loss_mm[:2, 1].sum() == pytest.approx(before[2:].mean(), rel=1e-9)
    assert year.c_y_per_rad > 0


def test_lateral_sliding_power_is_the_brush_tyres(year):
    """Straight driving has none; a steady corner's rear power is F_y V tan α_r with the
    brush slip angle the simulator chose (c_y, μ of the tyre)."""
    from tyrebayes._domain import load_vehicle
    from tyrebayes.simulate.drive import simulate_drive
    from tyrebayes.simulate.tyre_curves import brush_inverse_np

    car = load_vehicle("compact_fwd")
    _, truth = simulate_drive(4, car, "summer", duration_s=120.0, sample_rate_hz=10.0)
    p = lateral_sliding_power(truth, car)
    straight = np.abs(truth.ay_mps2) < 1e-9
    assert np.all(p[straight] < 1e-6)
    corner = np.abs(truth.ay_mps2) > 1.0
    assert corner.any()
    fz_rear = truth.wheel_load_n[:, 2:].sum(axis=1)
    fy_rear = (
        car.mass_kg * truth.ay_mps2
        - (
            car.yaw_inertia_kgm2 * np.gradient(truth.yaw_rate_radps, 0.1)
            + car.cog_to_rear_axle_m * car.mass_kg * truth.ay_mps2
        )
        / car.wheelbase_m
    )
    tan_r = brush_inverse_np(fy_rear / fz_rear, truth.c_y_per_rad, truth.mu_max)
    expected = np.abs(fy_rear * truth.vx_mps * tan_r)
    assert p[corner, 1] == pytest.approx(expected[corner], rel=0.02)
