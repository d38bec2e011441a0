"""``fleet-run`` end to end on a LocalCluster of 2 workers: killed mid-run, rerun, rerun again.

A small manifest (2 tyre sets x 2 simulated one-minute drives, a corrupt file, a drive of an
unknown vehicle) goes through the command in a subprocess that is killed (SIGKILL to its process
group: client, scheduler and workers) as soon as the first drives are recorded; the rerun must
skip exactly those, finish the rest, and leave every output once; a third run skips everything.
The fits use the linear tyre model: its compilation is the shortest, and the batch machinery,
not the model, is under test here. The JAX cache is the command's default, which the suite
points at its own folder (``tests/conftest.py``): the first run compiles, later runs load.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from distributed import get_task_stream

from tyrebayes._commands.fit_wear import drive_table
from tyrebayes._io import to_jsonable
from tyrebayes.batch import RunSettings, dask_client, fleet_run, read_manifest
from tyrebayes.batch.windows import WINDOW_COLUMNS
from tyrebayes.cli import main
from tyrebayes.inference.result import load_fit
from tyrebayes.internal.jax_cache import default_cache_dir
from tyrebayes.simulate.drive_io import write_drive
from tyrebayes.simulate.tyre_set import simulate_tyre_set_drives
from tyrebayes.streams.wear_evidence import WEAR_EVIDENCE_COLUMNS

pytestmark = pytest.mark.early  # minutes long: started first (tests/conftest.py)

MODEL = "linear"


@pytest.fixture(scope="module")
def manifest(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fleet_logs")
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
    (folder / "corrupt.parquet").write_bytes(b"PAR1 not a parquet file")
    rows.append({"path": "corrupt.parquet", "vehicle": "compact_fwd", "tyre_set_id": "set0",
                 "tyre_type": "winter", "surface": "dry"})  # fmt: skip
    (folder / "other.parquet").write_bytes((folder / "set1_0.parquet").read_bytes())
    rows.append({"path": "other.parquet", "vehicle": "no_such_car", "tyre_set_id": "set9"})
    path = folder / "manifest.csv"
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def _records(out: Path, stage: str) -> dict[str, dict]:
    return {
        p.name.removesuffix(".record.json"): json.loads(p.read_text())
        for p in sorted((out / stage).glob("*.record.json"))
    }


def _kill_after_first_drives(manifest: Path, out: Path) -> set[str]:
    """Start fleet-run in its own process group; SIGKILL it once 2 drives are recorded."""
    cmd = [sys.executable, "-m", "tyrebayes.cli", "fleet-run", str(manifest), "--out", str(out),
           "--workers", "2", "--model", MODEL, "--json"]  # fmt: skip
    proc = subprocess.Popen(
        cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    deadline = time.monotonic() + 240.0
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            if len(list((out / "drives").glob("*.record.json"))) >= 2:
                break
            time.sleep(0.05)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    return set(_records(out, "drives"))


def test_fleet_run_killed_rerun_and_skipped(manifest, tmp_path):
    out = tmp_path / "out"
    finished_before = _kill_after_first_drives(manifest, out)
    assert len(finished_before) >= 2

    items = read_manifest(manifest)
    settings = RunSettings(model=MODEL, jax_cache=default_cache_dir())
    with dask_client(workers=2) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        # The workers imported the package when they joined, before any task.
        imported = client.run(lambda: "tyrebayes.inference.tyre.fit" in sys.modules)
        assert list(imported.values()) == [True, True]
        summary = fleet_run(items, out, client, settings, progress=False)

    # Drives: the ones recorded before the kill were skipped, the rest ran now.
    drives = summary.drives
    assert drives.items == 6
    assert drives.skipped == len(finished_before)
    assert drives.failed == 2
    assert drives.done + drives.skipped + drives.failed_now == 6
    records = _records(out, "drives")
    assert set(records) == {i.drive_id for i in items}  # one record per drive, none extra
    reasons = {
        Path(r["path"]).name: r["reason"] for r in records.values() if r["status"] == "failed"
    }
    assert set(reasons) == {"corrupt.parquet", "other.parquet"}
    assert "no_such_car" in reasons["other.parquet"]
    assert all(r and "\n" not in r for r in reasons.values())

    # Every good drive: a windows table (the contract) and one summary row, once.
    good = [i for i in items if Path(i.path).name.startswith("set")]
    for item in good:
        windows = pd.read_parquet(out / "drives" / f"{item.drive_id}.windows.parquet")
        assert tuple(windows.columns) == WINDOW_COLUMNS and len(windows) > 0
        assert set(windows["drive_id"]) == {item.drive_id}
    summaries = pd.read_parquet(out / "drive_summaries.parquet")
    assert sorted(summaries["drive_id"]) == sorted(i.drive_id for i in good)
    # The table fit-wear reads (issue 24): the wear evidence, in manifest order.
    assert set(WEAR_EVIDENCE_COLUMNS) <= set(summaries.columns)
    order = {i.drive_id: k for k, i in enumerate(items)}
    assert list(summaries["drive_order"]) == [order[d] for d in summaries["drive_id"]]
    history, _ = drive_table([str(out / "drive_summaries.parquet")], "compact_fwd")
    assert len(history) == len(good) and (history["distance_km"] > 0).all()

    # Tyre sets: two fitted jointly over their two drives; the unknown car's set has no drive.
    sets = pd.read_parquet(out / "tyre_sets.parquet")
    assert sorted(sets["tyre_id"]) == ["set0", "set1"]
    assert (sets["n_drives"] == 2).all() and sets["converged"].all()
    assert set(sets["tyre_type"]) == {"winter", "summer"}
    # Simulated drives with normal driving measure C_x, and their surface labels are true.
    assert sets["c_x_measured"].all()
    assert (sets.filter(like="_prior_sds").abs().fillna(0.0) < 4.0).all().all()
    # One-minute drives hold no usable cornering: no c_y, and why, beside C_x (the drives that
    # were skipped on the rerun bring theirs back from their records).
    assert sets["c_y"].isna().all() and (sets["c_y_drives"] == 0).all()
    assert sets["lateral_reason"].str.contains("no usable cornering").all()
    assert "c_y" in pd.read_csv(out / "fleet" / "fleet_table.csv").columns
    for rec in _records(out, "tyre_sets").values():
        if rec["tyre_set_id"] == "set9":
            assert rec["status"] == "failed" and "no drive" in rec["reason"]
            continue
        fit = load_fit(out / "tyre_sets" / rec["outputs"][0], kind="tyre")
        row = sets[sets["tyre_id"] == rec["tyre_set_id"]].iloc[0]
        c_xr = np.asarray(fit.posterior["c_xr"]).mean()
        assert c_xr == pytest.approx(row["c_xr"], rel=1e-9)
        # Compact by default: no per-window draws, but what recomputes them.
        assert "posterior_predictive" not in fit.data.children
        assert "rho_score" in fit.data["constant_data"].data_vars
        assert 10.0 < row["c_xr"] < 100.0
    # Each task's memory as it ran: what it started with, its peak, whether its worker dropped
    # its compiled programs (which tasks drop depends on the scheduling: the rule itself is
    # tested in test_worker_memory.py; a set that drops them at a new fit shape can peak below
    # its start); the summary counts the drops of this run's sets.
    set_records = _records(out, "tyre_sets").values()
    ran = [*records.values(), *set_records]
    assert len(ran) == 6 + 3
    assert all(r["rss_mb_at_start"] > 0 and r["peak_rss_mb"] > 0 for r in ran)
    assert all(
        r["rss_mb_at_start"] <= r["peak_rss_mb"] + 1.0 for r in ran if not r["programs_dropped"]
    )
    assert all(isinstance(r["programs_dropped"], bool) for r in ran)
    assert summary.tyre_sets.programs_dropped == sum(r["programs_dropped"] for r in set_records)
    failures = pd.read_csv(out / "failures.csv")
    assert sorted(failures["item"]) == ["drive", "drive", "tyre_set"]

    # Fleet: recorded with its one-line reason when no set observed μ_max; table written.
    fleet = json.loads((out / "fleet" / "fleet.record.json").read_text())
    assert fleet["status"] in ("done", "failed") and "\n" not in fleet["reason"]
    assert (out / "fleet" / "fleet_table.csv").is_file()
    assert json.loads((out / "summary.json").read_text()) == to_jsonable(summary.to_dict())
    assert not [p for p in out.rglob(".*.tmp*")], "temporary files left behind"

    # A third run: nothing changed, nothing runs, nothing is rewritten.
    fits = sorted((out / "tyre_sets").glob("*.fit.nc"))
    stamps = [p.stat().st_mtime_ns for p in fits]
    with dask_client(workers=2) as client:
        again = fleet_run(items, out, client, settings, progress=False)
    assert again.drives.skipped == 6 and again.drives.done == 0
    assert again.tyre_sets.skipped == 3 and again.tyre_sets.done == 0
    assert again.fleet.skipped
    assert [p.stat().st_mtime_ns for p in fits] == stamps
    assert len(pd.read_parquet(out / "drive_summaries.parquet")) == 4


def test_fits_wait_for_the_drive_stage_tail(manifest, tmp_path):
    # set1's two drives first: it is ready while four drives are still to run. Sent to the
    # worker then, it would run before the drives the scheduler had not yet sent; held on the
    # client, it starts once no more drives are left than the worker has task slots (1).
    rows = pd.read_csv(manifest)
    first = rows["tyre_set_id"] == "set1"
    reordered = manifest.parent / "set1_first.csv"
    pd.concat([rows[first], rows[~first]]).to_csv(reordered, index=False)
    settings = RunSettings(model=MODEL, jax_cache=default_cache_dir())
    with dask_client(workers=1) as client, get_task_stream(client) as stream:
        summary = fleet_run(read_manifest(reordered), tmp_path / "out", client, settings)
    assert summary.tyre_sets.done == 2
    computed = {
        t["key"]: next(s for s in t["startstops"] if s["action"] == "compute") for t in stream.data
    }
    drive_ends = [c["stop"] for k, c in computed.items() if k.startswith("drive-")]
    set_starts = [c["start"] for k, c in computed.items() if k.startswith("tyre-set-")]
    assert len(drive_ends) == 6 and len(set_starts) == 3
    assert sum(end <= min(set_starts) for end in drive_ends) >= 6 - 1


def test_cli_bad_manifest_is_exit_2(tmp_path, capsys):
    bad = tmp_path / "m.csv"
    pd.DataFrame([{"path": "a.parquet", "vehicle": "compact_fwd"}]).to_csv(bad, index=False)
    assert main(["fleet-run", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("tyrebayes fleet-run: manifest: expected columns") and "\n" not in err
    assert main(["fleet-run", str(tmp_path / "none.csv"), "--out", str(tmp_path / "o")]) == 2
    assert "got no file" in capsys.readouterr().err


def test_cli_options(tmp_path, capsys):
    from tyrebayes._commands.fleet_run import MODEL_CHOICES
    from tyrebayes.inference.tyre.model import CURVE_MODELS, DEFAULT_MODEL

    assert set(MODEL_CHOICES) == set(CURVE_MODELS) and MODEL_CHOICES[0] == DEFAULT_MODEL
    manifest = tmp_path / "m.csv"
    pd.DataFrame([{"path": "a.parquet", "vehicle": "compact_fwd", "tyre_set_id": "s"}]).to_csv(
        manifest, index=False
    )
    assert main(["fleet-run", str(manifest), "--out", str(tmp_path / "o"), "--workers", "0"]) == 2
    assert "--workers: expected >= 1" in capsys.readouterr().err
    (tmp_path / "file").write_text("")
    assert main(["fleet-run", str(manifest), "--out", str(tmp_path / "file")]) == 2
    assert "expected a folder" in capsys.readouterr().err


@pytest.fixture
def separate_cluster(tmp_path):
    """A dask scheduler and one single-threaded worker, each a ``dask`` CLI process of its own.

    What ``--scheduler ADDRESS`` meets on a real cluster: nothing of it lives in the process
    that runs the command. Yields the scheduler's address; both processes are stopped after.
    """
    dask_cli = Path(sys.executable).parent / "dask"
    info = tmp_path / "scheduler.json"
    env = {**os.environ, "OMP_NUM_THREADS": "1", "JAX_PLATFORMS": "cpu"}
    common = {"env": env, "stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    scheduler = ["scheduler", "--port", "0", "--no-dashboard", "--scheduler-file", str(info)]
    procs = [subprocess.Popen([str(dask_cli), *scheduler], **common)]
    try:
        deadline = time.monotonic() + 60.0
        while not info.is_file() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]
        worker = ["worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard"]
        procs.append(subprocess.Popen([str(dask_cli), *worker], **common))
        yield address
    finally:
        for proc in reversed(procs):
            proc.terminate()
        for proc in procs:
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()


# In a worker: whether it imported the stages' modules (a bare ``dask worker`` does not). A
# lambda, so that it travels by value and unpickling it does not import this test module.
_STAGE_MODULES = frozenset({"tyrebayes.batch.drive_stage", "tyrebayes.inference.tyre.fit"})
_ran_fleet_tasks = lambda modules=_STAGE_MODULES: modules <= set(sys.modules)  # noqa: E731


def test_cli_runs_on_an_existing_cluster_at_its_address(
    manifest, separate_cluster, tmp_path, capsys
):
    # One tyre set's two drives and the corrupt file, on the separate cluster's one worker.
    rows = pd.read_csv(manifest)
    rows = rows[rows["path"].isin(["set0_0.parquet", "set0_1.parquet", "corrupt.parquet"])]
    small = manifest.parent / "small_manifest.csv"
    rows.to_csv(small, index=False)
    from distributed import Client

    with Client(separate_cluster, timeout="60s") as client:
        client.wait_for_workers(1, timeout=60)
        assert list(client.run(_ran_fleet_tasks).values()) == [False]
    out = tmp_path / "out"
    args = ["fleet-run", str(small), "--out", str(out), "--scheduler", separate_cluster]
    assert main([*args, "--workers", "1"]) == 2  # a cluster brings its own workers
    assert "--workers: expected only without --scheduler" in capsys.readouterr().err
    # 4: finished with failures (the corrupt file; one set is no fleet to fit either).
    assert main([*args, "--model", MODEL, "--json"]) == 4
    summary = json.loads(capsys.readouterr().out)
    assert summary["outcome"] == "failures"
    assert summary["workers"] == 1
    assert (summary["drives"]["done"], summary["drives"]["failed"]) == (2, 1)
    assert (summary["tyre_sets"]["done"], summary["tyre_sets"]["failed"]) == (1, 0)
    sets = pd.read_parquet(out / "tyre_sets.parquet")
    assert list(sets["tyre_id"]) == ["set0"] and sets["converged"].all()
    assert len(pd.read_parquet(out / "drive_summaries.parquet")) == 2
    # The work ran on the cluster's worker, not in this process, and the cluster outlives the
    # command (it is not the command's to close).
    with Client(separate_cluster, timeout="60s") as client:
        assert list(client.run(_ran_fleet_tasks).values()) == [True]
