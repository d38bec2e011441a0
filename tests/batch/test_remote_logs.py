"""Logs at fsspec URLs (issue 56): a manifest may list ``file://`` (or ``s3://``, ``memory://``)
URLs; the per-drive stage reads them where they are, with the same windows as the local file."""

from __future__ import annotations

import os
import time

import fsspec
import numpy as np
import pandas as pd
import pytest

from tyrebayes._errors import BadInputError
from tyrebayes.batch.drive_stage import process_drive
from tyrebayes.batch.manifest import manifest_from_table, read_manifest
from tyrebayes.batch.settings import RunSettings
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.simulate.drive_io import write_drive
from tyrebayes.streams import read_stream
from tyrebayes.streams.io import write_stream


@pytest.fixture(scope="module")
def drive_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("remote")
    df, truth = simulate_drive(5, "compact_fwd", "winter", duration_s=60.0, surface="snow")
    path = folder / "d.parquet"
    write_drive(df, truth, path)
    return path


def _row(path: str, **extra) -> dict:
    return {"path": path, "vehicle": "compact_fwd", "tyre_set_id": "s1", "tyre_type": "winter",
            "surface": "snow", "ambient_c": "-5", **extra}  # fmt: skip


def test_manifest_keeps_urls_and_knows_a_file_url_is_its_file(drive_file, tmp_path):
    url = drive_file.as_uri()  # file:///.../d.parquet
    table = pd.DataFrame([_row(url), _row("s3://bucket/logs/d.parquet?versionId=7")])
    pd.DataFrame(table).to_csv(tmp_path / "m.csv", index=False)
    local, remote = read_manifest(tmp_path / "m.csv")
    assert local.path == url and remote.path == "s3://bucket/logs/d.parquet?versionId=7"
    assert local.drive_id.startswith("d.parquet-") and remote.drive_id.startswith("d.parquet-")
    assert local.drive_id != remote.drive_id
    # The file under its path and its file:// URL is one log listed twice.
    with pytest.raises(BadInputError, match="expected each log once"):
        manifest_from_table(pd.DataFrame([_row(str(drive_file)), _row(url)]))


def test_a_file_url_gives_the_local_files_windows_and_summary(drive_file, tmp_path):
    settings = RunSettings()
    local = manifest_from_table(pd.DataFrame([_row(str(drive_file))]))[0]
    remote = manifest_from_table(pd.DataFrame([_row(drive_file.as_uri())]))[0]
    rec_local = process_drive(local, str(tmp_path / "local"), settings)
    rec_remote = process_drive(remote, str(tmp_path / "remote"), settings)
    assert rec_remote["status"] == rec_local["status"] == "done", rec_remote
    # The same windows and summary but for the names (the drive id hashes the path).
    for table, names in (("windows", ["drive_id"]), ("summary", ["drive_id", "path"])):
        a = pd.read_parquet(tmp_path / "remote" / "drives" / f"{remote.drive_id}.{table}.parquet")
        b = pd.read_parquet(tmp_path / "local" / "drives" / f"{local.drive_id}.{table}.parquet")
        assert len(a) == len(b) > 0
        pd.testing.assert_frame_equal(a.drop(columns=names), b.drop(columns=names))
    assert a["path"].item() == drive_file.as_uri()

    # A rerun skips the unchanged remote log, without reading it; a new version is redone.
    assert process_drive(remote, str(tmp_path / "remote"), settings)["skipped"] is True
    later = time.time() + 5.0
    os.utime(drive_file, (later, later))
    again = process_drive(remote, str(tmp_path / "remote"), settings)
    assert again["skipped"] is False and again["windows_hash"] == rec_remote["windows_hash"]


def test_a_missing_or_unreadable_url_is_a_failed_drive_with_one_line(tmp_path):
    settings = RunSettings()
    missing = (tmp_path / "nope.parquet").as_uri()
    for path, reason in [
        (missing, f"expected a readable file, got '{missing}'"),
        ("nosuchprotocol://x/d.parquet", "Protocol not known"),
    ]:
        item = manifest_from_table(pd.DataFrame([_row(path)]))[0]
        record = process_drive(item, str(tmp_path), settings)
        assert record["status"] == "failed" and reason in record["reason"], record
        assert "\n" not in record["reason"]


@pytest.mark.parametrize("suffix", [".parquet", ".csv", ".mf4"])
def test_read_stream_at_a_url_equals_the_local_file(tmp_path, suffix):
    df = pd.DataFrame(
        {"time": np.arange(5) * 0.01, "ax": np.linspace(0.0, 1.0, 5), "ay": np.zeros(5)}
    )
    path = tmp_path / f"s{suffix}"
    write_stream(df, path)
    expected = read_stream(path)
    pd.testing.assert_frame_equal(read_stream(path.as_uri()), expected)
    # An in-memory file system (fsspec's memory://): pyarrow reads it through fsspec.
    url = f"memory://tyrebayes-test/{os.getpid()}/s{suffix}"
    with fsspec.open(url, "wb") as fh:
        fh.write(path.read_bytes())
    try:
        pd.testing.assert_frame_equal(read_stream(url), expected)
    finally:
        fsspec.filesystem("memory").rm(url.removeprefix("memory://"))


def test_a_url_with_binary_data_named_csv_says_what_it_is(tmp_path, drive_file):
    path = tmp_path / "really.csv"
    path.write_bytes(drive_file.read_bytes())
    with pytest.raises(BadInputError, match="really.csv: expected CSV text, got a Parquet file"):
        read_stream(path.as_uri())
