"""The benchmarks' one data module: every shared data set found, drives selected by name."""

from __future__ import annotations

import pytest

from benchmarks._data import (
    external_drives,
    external_lateral_drives,
    niki_lateral_log,
    rav4_segment,
    rav4_segment_path,
    stanford_lateral_log,
    wear_by_tyre_type,
)


def test_external_sets_are_found_in_name_order():
    braking = external_drives()
    cornering = external_lateral_drives()
    assert len(braking) == 16 and len(cornering) == 8
    for drives in (braking, cornering):
        names = [d.name for d in drives]
        assert names == sorted(names)
        assert all(d.path.exists() and d.vehicle_path.exists() for d in drives)
    assert braking[0].truth_samples_path().exists()
    assert {"c_y_front", "c_y_rear", "surface"} <= set(cornering[0].truth)


def test_drives_are_selected_by_name_and_an_unknown_name_is_refused():
    assert [d.name for d in external_lateral_drives(names="l03,l00.parquet")] == ["l00", "l03"]
    with pytest.raises(SystemExit, match="got \\['l99'\\]"):
        external_lateral_drives(names="l99")


def test_real_lateral_logs_have_the_reference_columns():
    columns = {"time", "speed_reference", "lateral_velocity", "yaw_rate", "ay"}
    for frame in (stanford_lateral_log(), niki_lateral_log("High_Speed2")):
        assert columns | {"wheel_angle_front"} <= set(frame.columns)
        assert frame["time"].is_monotonic_increasing
        assert not frame["wheel_angle_front"].isna().any()


def test_a_drive_reads_its_stream_and_truth_samples_as_written():
    (drive,) = external_drives(names="e00")
    frame, truth = drive.frame(), drive.truth_samples()
    assert {"time", "wheel_speed_fl"} <= set(frame.columns)
    assert len(truth) > 0


def test_the_shipped_data_are_found_in_the_package():
    assert rav4_segment_path().parent.name == "data"
    assert rav4_segment_path().parent.parent.name == "tyrebayes"
    assert len(rav4_segment()) > 0
    assert {"winter", "summer"} <= set(wear_by_tyre_type()["tyre_type"])
