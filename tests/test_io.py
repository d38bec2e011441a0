"""Atomic writers (tyrebayes._io): recognisable temporary names, swept after a killed writer."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from tyrebayes import _interrupts
from tyrebayes._io import (
    atomic_output,
    atomic_path,
    atomic_write_bytes,
    sweep_folder_temporaries,
    sweep_stale_temporaries,
)
from tyrebayes.streams import write_stream


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_temporary_names_are_recognisable(tmp_path):
    tmp, final = atomic_path(tmp_path / "fit.nc")
    assert tmp.name == f".fit.nc.{os.getpid()}.tmp.nc" and final == tmp_path / "fit.nc"


def test_a_killed_writers_file_is_swept_by_the_next_write(tmp_path):
    dead = _dead_pid()
    stale = tmp_path / f".fit.nc.{dead}.tmp.nc"
    mine = tmp_path / f".fit.nc.{os.getpid()}.tmp.nc"  # this process may be writing it
    other_target = tmp_path / f".fit2.nc.{dead}.tmp.nc"
    old_live = tmp_path / f".fit.nc.{os.getppid()}.tmpabc"
    for p in (stale, mine, other_target, old_live):
        p.write_bytes(b"half a file")
    two_days_ago = time.time() - 2 * 24 * 3600
    os.utime(old_live, (two_days_ago, two_days_ago))  # a live PID, but a reused one by now

    atomic_write_bytes(tmp_path / "fit.nc", b"whole")

    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["fit.nc", mine.name, other_target.name]
    )
    assert (tmp_path / "fit.nc").read_bytes() == b"whole"


def test_a_live_writers_file_is_kept(tmp_path):
    live = tmp_path / f".fit.nc.{os.getppid()}.tmp.nc"
    live.write_bytes(b"being written")
    assert sweep_stale_temporaries(tmp_path / "fit.nc") == []
    assert live.exists()


def test_stream_writer_sweeps_too(tmp_path):
    stale = tmp_path / f".drive.csv.{_dead_pid()}.tmp.csv"
    stale.write_text("time\n0.0\n")
    write_stream(pd.DataFrame({"time": [0.0, 0.01]}), tmp_path / "drive.csv")
    assert [p.name for p in tmp_path.iterdir()] == ["drive.csv"]


def test_sweeping_a_missing_folder_is_a_no_op(tmp_path):
    assert sweep_stale_temporaries(tmp_path / "nope" / "fit.nc") == []


def test_to_jsonable_writes_a_fits_diagnostics_as_their_dict():
    import json

    from tyrebayes._io import to_jsonable
    from tyrebayes.inference.diagnostics import Diagnostics

    diagnostics = Diagnostics(
        method="fast",
        n_chains=1,
        n_draws=4000,
        r_hat_max=float("nan"),
        ess_bulk_min=4000.0,
        ess_tail_min=4000.0,
        divergences=0,
        optimiser_result="successful",
        converged=True,
        reasons=(),
    )
    record = to_jsonable({"diagnostics": diagnostics, "x": np.float64("nan")})
    assert record["diagnostics"] == to_jsonable(diagnostics.as_dict())
    assert record["x"] is None
    json.dumps(record)


# --- modes and interruptions (issue 57) --------------------------------------------------------


def test_files_get_the_mode_the_umask_gives(tmp_path):
    # mkstemp makes 0600: summary.json, failures.csv and the records were unreadable to others.
    previous = os.umask(0o027)
    try:
        atomic_write_bytes(tmp_path / "a.json", b"{}")
        assert (tmp_path / "a.json").stat().st_mode & 0o777 == 0o640
        os.umask(0o022)
        atomic_write_bytes(tmp_path / "b.json", b"{}")
        assert (tmp_path / "b.json").stat().st_mode & 0o777 == 0o644
    finally:
        os.umask(previous)


def test_a_signal_while_writing_drops_the_new_file_and_keeps_the_old(tmp_path):
    target = tmp_path / "out.csv"
    target.write_text("old")
    with _interrupts.signals_as_interruptions():
        try:
            with atomic_output(target) as tmp:
                tmp.write_text("new, complete")
                os.kill(os.getpid(), signal.SIGINT)  # held: the file is written to its end
                tmp.write_text("new, complete, and then some")
            raise AssertionError("the held signal was not raised")
        except _interrupts.Interrupted as err:
            assert err.signum == signal.SIGINT and err.exit_status == 130
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


def test_nothing_is_written_after_a_swallowed_interruption(tmp_path):
    with _interrupts.signals_as_interruptions():
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1.0)
        except BaseException:  # noqa: BLE001 -- what a careless library does
            pass
        assert _interrupts.pending() == signal.SIGTERM
        with pytest.raises(_interrupts.Interrupted):
            atomic_write_bytes(tmp_path / "a.json", b"{}")
        with pytest.raises(_interrupts.Interrupted):
            write_stream(pd.DataFrame({"time": [0.0]}), tmp_path / "s.csv")
    assert list(tmp_path.iterdir()) == []
    assert _interrupts.pending() is None  # each command starts afresh


def test_a_folder_is_swept_of_dead_writers_files_only(tmp_path):
    dead = _dead_pid()
    stale = [tmp_path / f".a.json.{dead}.tmpx1", tmp_path / f".b.parquet.{dead}.tmp.parquet"]
    live = tmp_path / f".c.json.{os.getpid()}.tmpx2"
    for p in (*stale, live):
        p.write_bytes(b"half")
    assert sorted(sweep_folder_temporaries(tmp_path)) == sorted(stale)
    assert sorted(p.name for p in tmp_path.iterdir()) == [live.name]
