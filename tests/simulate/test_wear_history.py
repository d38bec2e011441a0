"""A simulated year of wearing tyres: files with an odometer, radii that shrink, tyre changes."""

import numpy as np
import pytest

from tyrebayes.simulate.wear_history import simulate_wear_year
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
    assert year.change_drive_index == (3,) and year.change_kind == ("rotation",)
    # before the rotation the driven front tyres lose more than the rear ones
    assert (d[0, :2] - d[2, :2]).min() > (d[0, 2:] - d[2, 2:]).max()
    # at the rotation the front tyres go to the rear (same side)
    assert np.all(d[3, 2:] <= d[2, :2]) and np.all(d[3, :2] <= d[2, 2:])
    assert np.all(d[2, :2] - d[3, 2:] > d[2, 2:] - d[3, :2])  # still driven hardest: the front
    assert d[3, 2:].mean() < d[3, :2].mean()
    assert np.all(year.drive_work_j[:, 0] > 0) and np.all(year.drive_work_j >= 0)
    assert set(year.readings["axle"]) == {"front", "rear"}
