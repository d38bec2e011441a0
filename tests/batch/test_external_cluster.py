"""``fleet-run --scheduler ADDR`` on a cluster whose scheduler and workers are their own processes.

A ``dask scheduler`` on loopback and two ``dask worker`` processes (one process, one thread each)
are started as a multi-node cluster's would be, with the environment a local cluster gives its
workers (``run._worker_env``: one thread for BLAS and XLA's kernels, the same XLA flags, so that
the two clusters share compiled programs through the JAX cache and compute bit for bit alike).
The same small manifest as ``test_run.py`` (2 tyre sets x 2 simulated one-minute drives, the
linear tyre model) goes through the command on it and on a ``LocalCluster`` of 2 workers; the
tables must be equal. The processes are killed, whole process groups, whatever happens.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import dask
import pandas as pd
import pytest

from tyrebayes.batch.cluster import _worker_env
from tyrebayes.cli import main
from tyrebayes.simulate.drive_io import write_drive
from tyrebayes.simulate.tyre_set import simulate_tyre_set_drives

pytestmark = pytest.mark.early  # a whole command twice, and a cluster started: first

MODEL = "linear"


@pytest.fixture(scope="module")
def manifest(tmp_path_factory):
    """Two tyre sets of two one-minute drives (test_run.py's seeds: its programs are cached)."""
    folder = tmp_path_factory.mktemp("external_logs")
    rows = []
    for k, tyre_type in enumerate(("winter", "summer")):
        drives = simulate_tyre_set_drives(
            10 + k, "compact_fwd", tyre_type, n_drives=2, duration_s=60.0, surfaces=("snow", "dry")
        )
        for j, (df, truth) in enumerate(drives):
            path = folder / f"set{k}_{j}.parquet"
            write_drive(df, truth, path)
            rows.append(
                {"path": path.name, "vehicle": "compact_fwd", "tyre_set_id": f"set{k}",
                 "tyre_type": tyre_type, "surface": truth.surface, "ambient_c": truth.ambient_c}
            )  # fmt: skip
    path = folder / "manifest.csv"
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(proc: subprocess.Popen) -> None:
    """SIGTERM to the process group (a worker's nanny and its worker), SIGKILL if it lingers."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=15)


@contextlib.contextmanager
def external_cluster(logs: Path, n_workers: int = 2):
    """A scheduler and ``n_workers`` workers on loopback, each its own process (group)."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, **_worker_env()}
    procs: list[subprocess.Popen] = []

    def start(name: str, args: list[str]) -> None:
        log = open(logs / f"{name}.log", "wb")  # noqa: SIM115 -- closed with the process
        procs.append(
            subprocess.Popen(
                [sys.executable, "-m", *args],
                env=env,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,  # its own group: torn down whole, apart from pytest's
            )
        )
        log.close()

    try:
        start("scheduler", ["distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                            "--port", str(port), "--no-dashboard"])  # fmt: skip
        for k in range(n_workers):
            start(f"worker{k}", ["distributed.cli.dask_worker", address, "--nworkers", "1",
                                 "--nthreads", "1", "--memory-limit", "4GiB",
                                 "--no-dashboard", "--name", f"ext-{k}"])  # fmt: skip
        from distributed import Client

        deadline = time.monotonic() + 60.0
        while True:  # the scheduler takes a moment to listen
            try:
                with Client(address, timeout="5s") as client:
                    client.wait_for_workers(
                        n_workers, timeout=max(1.0, deadline - time.monotonic())
                    )
                break
            except OSError:
                if time.monotonic() > deadline or procs[0].poll() is not None:
                    raise
                time.sleep(0.5)
        yield address
    finally:
        for proc in reversed(procs):  # workers first: they would wait for a lost scheduler
            _stop(proc)


def _fleet_run(capsys, manifest: Path, out: Path, *cluster: str) -> tuple[int, dict]:
    argv = ["fleet-run", str(manifest), "--out", str(out), "--model", MODEL, "--json"]
    code = main([*argv, *cluster])
    captured = capsys.readouterr()
    return code, json.loads(captured.out)


def test_fleet_run_on_external_scheduler_and_workers_matches_local_cluster(
    manifest, tmp_path, capsys
):
    local_out, ext_out = tmp_path / "local", tmp_path / "external"
    local_code, local = _fleet_run(capsys, manifest, local_out, "--workers", "2")

    with external_cluster(tmp_path) as address:
        code, summary = _fleet_run(capsys, manifest, ext_out, "--scheduler", address)
        from distributed import Client

        with Client(address) as client:
            workers = client.scheduler_info()["workers"].values()
            # The workers are the ones started here, and the run's plugin reached them.
            assert sorted(w["name"] for w in workers) == ["ext-0", "ext-1"]
            imported = client.run(lambda: "tyrebayes.inference.tyre.fit" in sys.modules)
            assert list(imported.values()) == [True, True]
            pids = set(client.run(os.getpid).values())
            assert os.getpid() not in pids and len(pids) == 2

    # No ABS stop in these drives: the fleet model has nothing to fit (exit 4), alike.
    assert code == local_code == 4
    assert summary["workers"] == local["workers"] == 2
    for stage in ("drives", "tyre_sets"):
        assert summary[stage]["done"] == local[stage]["done"] == summary[stage]["items"]
    assert summary["drives"]["items"] == 4 and summary["tyre_sets"]["items"] == 2
    assert summary["fleet"]["reason"] == local["fleet"]["reason"]

    for table in ("drive_summaries.parquet", "tyre_sets.parquet"):
        pd.testing.assert_frame_equal(
            pd.read_parquet(ext_out / table), pd.read_parquet(local_out / table)
        )
    windows = sorted(p.name for p in (local_out / "drives").glob("*.windows.parquet"))
    assert len(windows) == 4
    assert windows == sorted(p.name for p in (ext_out / "drives").glob("*.windows.parquet"))
    for name in windows:
        pd.testing.assert_frame_equal(
            pd.read_parquet(ext_out / "drives" / name),
            pd.read_parquet(local_out / "drives" / name),
        )
    assert (ext_out / "failures.csv").read_text() == (local_out / "failures.csv").read_text()


def test_unreachable_scheduler_is_one_line_and_exit_2(manifest, tmp_path, capsys):
    address = f"tcp://127.0.0.1:{_free_port()}"  # nothing listens there
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        code = main(["fleet-run", str(manifest), "--out", str(tmp_path / "o"),
                     "--scheduler", address])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1
    assert "expected a reachable dask scheduler" in err and address in err
