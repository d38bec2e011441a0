"""A fleet run tells the truth (issue 57): exit 0 / 4 / 2 by its outcome, a table replaced only by
a complete one, and an interruption that is not recorded as a failure.

The end-to-end cases use logs that fail at once (corrupt files), or a Ctrl-C during the drive
stage, on one local worker: no tyre-set fit is compiled, and each case takes seconds.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from tyrebayes import _interrupts
from tyrebayes.batch import RunSettings, manifest_from_table, process_drive
from tyrebayes.batch.records import stopping
from tyrebayes.cli import main
from tyrebayes.simulate.drive_io import write_drive
from tyrebayes.simulate.tyre_set import simulate_tyre_set_drives


def test_a_failure_while_stopping_is_not_recorded(tmp_path, monkeypatch):
    # A drive whose reading fails because the run is being stopped (here: a signal came) has
    # no record afterwards, so the rerun does it again; a failure of the log itself has one.
    corrupt = tmp_path / "corrupt.parquet"
    corrupt.write_bytes(b"PAR1 garbage")
    row = {"path": str(corrupt), "vehicle": "compact_fwd", "tyre_set_id": "s"}
    item = manifest_from_table(pd.DataFrame([row]))[0]
    record = tmp_path / "drives" / f"{item.drive_id}.record.json"
    assert not stopping()
    monkeypatch.setattr(_interrupts, "_pending", signal.SIGINT)
    assert stopping()
    with pytest.raises(Exception, match="cannot parse"):
        process_drive(item, str(tmp_path), RunSettings())
    assert not record.exists()
    monkeypatch.setattr(_interrupts, "_pending", None)
    assert process_drive(item, str(tmp_path), RunSettings())["status"] == "failed"
    assert json.loads(record.read_text())["status"] == "failed"


def _manifest(folder: Path, rows: list[dict]) -> Path:
    path = folder / "manifest.csv"
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def test_every_item_failed_is_exit_2_and_keeps_the_last_table(tmp_path, capsys):
    for name in ("a", "b"):
        (tmp_path / f"{name}.parquet").write_bytes(b"PAR1 not a parquet file")
    manifest = _manifest(
        tmp_path,
        [
            {"path": "a.parquet", "vehicle": "compact_fwd", "tyre_set_id": "s1"},
            {"path": "b.parquet", "vehicle": "compact_fwd", "tyre_set_id": "s2"},
        ],
    )
    out = tmp_path / "out"
    out.mkdir()
    last = pd.DataFrame({"tyre_id": ["old"], "c_xr": [40.0]})
    last.to_parquet(out / "tyre_sets.parquet")
    argv = ["fleet-run", str(manifest), "--out", str(out), "--workers", "1", "--json"]
    assert main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err
    assert err.count("\n") == 1 and "nothing usable: no tyre set was fitted" in err
    assert "2 of 2 drives and 2 of 2 tyre sets failed" in err
    summary = json.loads(captured.out)
    assert summary["outcome"] == "nothing_usable" and "tyre_sets" not in summary["written"]
    # Every failure that makes the exit status is listed, the fleet model's too.
    assert (
        sorted(f["item"] for f in summary["failures"])
        == ["drive"] * 2 + ["fleet"] + ["tyre_set"] * 2
    )
    # Not replaced by an empty table: the last complete one stands.
    pd.testing.assert_frame_equal(pd.read_parquet(out / "tyre_sets.parquet"), last)
    failures = pd.read_csv(out / "failures.csv")
    assert sorted(failures["item"]) == ["drive", "drive", "tyre_set", "tyre_set"]
    # Output files are readable as the umask says, not 0600.
    mask = os.umask(0)
    os.umask(mask)
    for name in ("summary.json", "failures.csv"):
        assert (out / name).stat().st_mode & 0o777 == 0o666 & ~mask, name
    assert not list(out.rglob(".*.tmp*"))


def test_a_file_where_a_stage_folder_belongs_is_one_line_before_any_work(tmp_path, capsys):
    (tmp_path / "a.parquet").write_bytes(b"")
    manifest = _manifest(
        tmp_path, [{"path": "a.parquet", "vehicle": "compact_fwd", "tyre_set_id": "s"}]
    )
    out = tmp_path / "out"
    out.mkdir()
    (out / "drives").write_text("")
    assert main(["fleet-run", str(manifest), "--out", str(out), "--workers", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "drives to be a folder (or not to exist), got a file" in err
    assert sorted(p.name for p in out.iterdir()) == ["drives"]  # nothing run, nothing written


@pytest.fixture(scope="module")
def drives(tmp_path_factory):
    """Six one-minute drives of one tyre set."""
    folder = tmp_path_factory.mktemp("drives")
    rows = []
    simulated = simulate_tyre_set_drives(
        21, "compact_fwd", "winter", n_drives=6, duration_s=60.0, surfaces=("dry",)
    )
    for j, (df, truth) in enumerate(simulated):
        write_drive(df, truth, folder / f"d{j}.parquet")
        rows.append({"path": f"d{j}.parquet", "vehicle": "compact_fwd", "tyre_set_id": "s1",
                     "tyre_type": "winter", "surface": "dry"})  # fmt: skip
    return _manifest(folder, rows)


def test_ctrl_c_during_the_drive_stage_records_no_failure(drives, tmp_path):
    # Ctrl-C reaches the terminal's whole process group: the client and its local workers.
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "tyrebayes.cli", "fleet-run", str(drives), "--out", str(out),
           "--workers", "1", "--model", "linear"]  # fmt: skip
    proc = subprocess.Popen(
        cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    try:
        deadline = time.monotonic() + 180.0
        while time.monotonic() < deadline and proc.poll() is None:
            if list((out / "drives").glob("*.record.json")):
                break
            time.sleep(0.02)
        assert proc.poll() is None, proc.stderr.read().decode()
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    err = err.decode()
    assert proc.returncode == 130, err
    assert err == "tyrebayes fleet-run: interrupted (SIGINT)\n"
    records = [json.loads(p.read_text()) for p in out.rglob("*.record.json")]
    assert 1 <= len(records) < 6
    assert all(r["status"] == "done" for r in records), records
    # A cut run writes no table; its killed writers' temporary files are swept.
    assert not (out / "tyre_sets.parquet").exists() and not (out / "failures.csv").exists()
    assert not list(out.rglob(".*.tmp*"))
