"""The per-drive stage: windows table (the contract), summary row, records, skips and failures."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.batch.drive_stage import process_drive
from tyrebayes.batch.manifest import manifest_from_table
from tyrebayes.batch.settings import RunSettings
from tyrebayes.batch.windows import WINDOW_COLUMNS, drives_from_windows
from tyrebayes.inference.tyre.data import observations_from_features
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.simulate.drive_io import write_drive
from tyrebayes.streams import compute_features, read_stream, validate_stream
from tyrebayes.streams.segments import SEGMENT_REGIMES
from tyrebayes.streams.tyre_temperature import features_tyre_temperature


@pytest.fixture(scope="module")
def drive_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("drive")
    df, truth = simulate_drive(5, "compact_fwd", "winter", duration_s=60.0, surface="snow")
    path = folder / "d.parquet"
    write_drive(df, truth, path)
    return path, truth


def _item(path, vehicle="compact_fwd", ambient=""):
    table = pd.DataFrame(
        [{"path": str(path), "vehicle": vehicle, "tyre_set_id": "s1", "tyre_type": "winter",
          "surface": "snow", "ambient_c": ambient}]
    )  # fmt: skip
    return manifest_from_table(table)[0]


def test_windows_table_is_the_pipelines_windows(drive_file, tmp_path):
    path, truth = drive_file
    item = _item(path, ambient=str(truth.ambient_c))
    record = process_drive(item, str(tmp_path), RunSettings())
    assert record["status"] == "done" and not record["skipped"], record
    table = pd.read_parquet(tmp_path / "drives" / f"{item.drive_id}.windows.parquet")
    assert tuple(table.columns) == WINDOW_COLUMNS
    assert len(table) == record["windows"] > 0
    # The same windows as the library computes from the log directly.
    vehicle = load_vehicle("compact_fwd")
    feats = compute_features(validate_stream(read_stream(path), vehicle), vehicle)
    temperature = features_tyre_temperature(feats, ambient_c=truth.ambient_c)
    expected = observations_from_features(feats, temperature_c=temperature)
    (drive,), surfaces = drives_from_windows(table)
    assert surfaces == ["snow"]
    assert drive.to_dict().keys() == expected.to_dict().keys()
    for key, values in drive.to_dict().items():
        np.testing.assert_array_equal(values, expected.to_dict()[key], err_msg=key)
    row = pd.read_parquet(tmp_path / "drives" / f"{item.drive_id}.summary.parquet")
    assert len(row) == 1
    row = row.iloc[0]
    assert row["drive_id"] == item.drive_id and row["tyre_set_id"] == "s1"
    assert row["duration_s"] == pytest.approx(60.0, abs=0.1)
    assert row["windows"] == len(table)
    total = sum(row[f"seconds_{k}"] for k in SEGMENT_REGIMES)
    assert total == pytest.approx(row["duration_s"], rel=0.02)
    assert row["friction_work_driven_j"] > 0


def test_rerun_skips_unchanged_and_redoes_changed(drive_file, tmp_path):
    path, _ = drive_file
    item = _item(path)
    first = process_drive(item, str(tmp_path), RunSettings())
    again = process_drive(item, str(tmp_path), RunSettings())
    assert again["skipped"] and again["input_hash"] == first["input_hash"]
    # Other settings: the drive runs again (whatever its outcome) and its record says so.
    other_window = process_drive(item, str(tmp_path), RunSettings(window_s=0.3))
    assert not other_window["skipped"]
    assert other_window["settings"]["window_s"] == 0.3
    # Changed content at the same path: a new hash, processed again.
    copy = tmp_path / "copy.parquet"
    df = pd.read_parquet(path)
    df.to_parquet(copy, index=False)
    item_copy = _item(copy)
    process_drive(item_copy, str(tmp_path), RunSettings())
    df["ax"] = df["ax"] + 0.01
    df.to_parquet(copy, index=False)
    redone = process_drive(item_copy, str(tmp_path), RunSettings())
    assert not redone["skipped"] and redone["status"] == "done"


def test_bad_logs_are_failed_records_with_one_line(tmp_path, drive_file):
    corrupt = tmp_path / "corrupt.parquet"
    corrupt.write_bytes(b"PAR1 garbage")
    cases = {
        "corrupt": _item(corrupt),
        "unknown vehicle": _item(drive_file[0], vehicle="no_such_car"),
        "missing": _item(tmp_path / "missing.parquet"),
    }
    for name, item in cases.items():
        record = process_drive(item, str(tmp_path), RunSettings())
        assert record["status"] == "failed", name
        assert record["reason"] and "\n" not in record["reason"], name
        stored = json.loads((tmp_path / "drives" / f"{item.drive_id}.record.json").read_text())
        assert stored["reason"] == record["reason"]
    assert (
        "no_such_car"
        in process_drive(cases["unknown vehicle"], str(tmp_path), RunSettings())["reason"]
    )


def test_a_raw_can_log_with_a_profile(tmp_path):
    from tyrebayes.simulate.can_log import stream_messages, write_can_log
    from tyrebayes.streams.can import load_dbc, load_profile

    vehicle = load_vehicle("suv_rav4")
    df, _ = simulate_drive(6, "suv_rav4", "summer", duration_s=60.0, surface="dry")
    profile = load_profile("toyota_rav4_2017")
    messages = stream_messages(
        df.fillna(0.0), profile, load_dbc(profile.dbc_path()), wheel_radius_m=vehicle.wheel_radius_m
    )
    log = write_can_log(messages, tmp_path / "drive.log")
    table = pd.DataFrame(
        [{"path": str(log), "vehicle": "suv_rav4", "tyre_set_id": "rav4",
          "profile": "toyota_rav4_2017"}]
    )  # fmt: skip
    item = manifest_from_table(table)[0]
    record = process_drive(item, str(tmp_path), RunSettings())
    assert record["status"] == "done", record["reason"]
    windows = pd.read_parquet(tmp_path / "drives" / f"{item.drive_id}.windows.parquet")
    assert len(windows) == record["windows"] > 0
    assert record["time_faults_repaired"] == ""
    # Time faults (issue 57): a few frames written late are repaired and said in the record; a
    # reversed log fails the drive with its one-line reason.
    lines = log.read_text().splitlines(keepends=True)
    late = lines[:1000] + lines[1004:1008] + lines[1000:1004] + lines[1008:]
    reversed_ = lines[::-1]
    for name, text in (("late", late), ("reversed", reversed_)):
        faulty = tmp_path / f"{name}.log"
        faulty.write_text("".join(text))
        row = table.assign(path=str(faulty))
        record = process_drive(manifest_from_table(row)[0], str(tmp_path), RunSettings())
        if name == "late":
            assert record["status"] == "done", record["reason"]
            assert "CAN time faults repaired: WHEEL_SPEEDS: 1 of" in record["time_faults_repaired"]
        else:
            assert record["status"] == "failed" and "a reversed log?" in record["reason"]
