"""The cornering stiffness behind the wear evidence's lateral work, from a history's own drives."""

from pathlib import Path

import pytest

from tyrebayes import load_vehicle, read_stream, validate_stream
from tyrebayes.inference.wear.cornering import (
    DrivesCornering,
    cornering_stiffness_from_drives,
)

CAR = load_vehicle("compact_fwd")


def _frames(paths, taken=None):
    for p in paths:
        if taken is not None:
            taken.append(p)
        yield Path(p).name, validate_stream(read_stream(p), CAR).data


@pytest.fixture(scope="module")
def short_year(tmp_path_factory):
    """Drives of 90 s: too little cornering for a lateral fit."""
    from tyrebayes.simulate.wear_history import simulate_wear_year

    truth = simulate_wear_year(
        4, tmp_path_factory.mktemp("short"), n_drives=4, drive_s=90.0, km_per_year=4000.0
    )
    return truth.stream_paths


def test_drives_without_cornering_give_none_and_each_reason(short_year):
    found = cornering_stiffness_from_drives(_frames(short_year), CAR)
    assert found.stiffness is None and found.drive == ""
    assert [name for name, _ in found.tries] == [Path(p).name for p in short_year]
    assert all("no usable cornering" in reason for _, reason in found.tries)
    assert found.note.startswith("no usable lateral fit among the first 4 drives")
    assert found.note.endswith("the type prior's c_y is used")


def test_at_most_tries_drives_are_read(short_year):
    taken = []
    found = cornering_stiffness_from_drives(_frames(short_year, taken), CAR, tries=2)
    assert len(found.tries) == 2 and len(taken) == 2  # the later drives are never read


def test_tries_below_one_is_refused():
    with pytest.raises(ValueError, match="tries: expected at least 1, got 0"):
        cornering_stiffness_from_drives(iter(()), CAR, tries=0)


def test_no_drives_says_so():
    assert DrivesCornering(None, "", ()).note.startswith("no drive to fit the cornering of")


def test_the_first_usable_fit_gives_the_stiffness(tmp_path):
    """Drives of four minutes corner enough: the first whose fit is usable gives each axle's c_y
    near the simulated tyre's, and the drives after it are not read."""
    from tyrebayes.simulate.wear_history import simulate_wear_year

    truth = simulate_wear_year(
        4, tmp_path, n_drives=5, drive_s=240.0, km_per_year=4000.0, rotation_at=None
    )
    taken = []
    found = cornering_stiffness_from_drives(_frames(truth.stream_paths, taken), CAR)
    assert found.stiffness is not None and found.stiffness.source == "lateral_fit"
    assert found.tries[-1] == (found.drive, "")
    assert len(taken) == len(found.tries) < 5
    for c_y in found.stiffness.per_axle:
        assert c_y == pytest.approx(truth.c_y_per_rad, rel=3 * found.stiffness.log_sd)
    assert found.note == f"c_y from the lateral fit of {found.drive}"
