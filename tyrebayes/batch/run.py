"""A fleet run on dask.distributed: drives map over workers, tyre sets reduce, the fleet closes.

:func:`fleet_run` submits one task per drive (:func:`~.drive_stage.process_drive`). A set's joint
fit (:func:`~.tyre_set_stage.fit_tyre_set`) is ready once its drives have finished (done, failed or
skipped); ready fits are held on the client until the drives still to finish are no more than the
cluster's task slots, then submitted at a priority below every drive's, larger padded shapes
higher: they fill the drive stage's idle tail. Each worker is given a contiguous run of them, of
about equal work (:func:`~.placement.place_sets`), so that it meets few fit shapes, each once (it
keeps one shape's programs). When all sets are in, it writes the run's tables and runs the fleet
stage (:func:`~.fleet_stage.run_fleet_stage`) on the client. Every item writes its own outputs
atomically when it finishes, so a killed run loses only the items in flight, and a rerun skips what
its records say is unchanged.

Outputs in ``out``: ``drives/`` (per drive: ``ID.windows.parquet``, the windows table a set's
fit reads; ``ID.summary.parquet``; the record), ``tyre_sets/`` (per set: ``ID.fit.nc``,
``ID.row.parquet``, the record), ``drive_summaries.parquet`` and ``tyre_sets.parquet`` (the
rows gathered), ``failures.csv`` (item, id, path, one-line reason), ``fleet/`` and
``summary.json`` (:func:`fleet_run`'s return value). A gathered table replaces the previous one
only when the run has rows for it: a run in which every tyre set failed leaves the last
``tyre_sets.parquet`` as it was (the summary says it was not written).

An interruption (SIGINT, SIGTERM: :mod:`tyrebayes._interrupts`) ends the run without recording
the items in flight: they have no record and run again next time, and the tables are not
written. A local cluster's workers ignore Ctrl-C (it reaches the terminal's whole process
group): the client stops them when it closes the cluster.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

import pandas as pd

from .. import _interrupts
from .._errors import BadInputError
from .._io import atomic_write_bytes, sweep_folder_temporaries, to_jsonable
from .drive_stage import DRIVES_DIR, process_drive
from .fleet_stage import FLEET_DIR, run_fleet_stage
from .manifest import DriveItem
from .placement import place_sets
from .records import write_parquet
from .settings import RunSettings
from .tyre_set_stage import TYRE_SETS_DIR, fit_tyre_set, pad_size, set_file_name, tyre_set_table
from .worker_memory import peak_rss_mb

#: Memory limit of each local worker, the hard stop above the tasks' budget
#: (``RunSettings.memory_budget_mb``): without the budget a fast fit of a set of four 10-60 min
#: drives held up to 1.8 GB at its peak and a drive task up to 1.9 GB (the ``fleet_run``
#: benchmark at full size); the limit leaves room above that for a larger set.
DEFAULT_MEMORY_LIMIT = "4GiB"
# Tyre-set tasks' priorities are their padded shape minus this: below every drive task's 0.
_SET_PRIORITY_OFFSET = 1 << 40

# The tasks keep no data in the workers (they write files and return small records), so dask's
# spilling and pausing only get in the way: memory that JAX and the allocator keep after a fit
# does not come back, and a paused single worker never resumes. The limit stays as the nanny's
# hard stop (a worker over 95 % is restarted and its task recorded as failed).
# The nannies' default MALLOC_TRIM_THRESHOLD_ is unset (None removes it): it turns off glibc's
# dynamic mmap threshold, and every large array then page-faults afresh
# (:func:`.worker_memory.reuse_freed_arrays`, which repairs it on other clusters' workers). The
# freed heap still goes back after each task (:func:`.worker_memory.release_free_memory`).
_WORKER_MEMORY_CONFIG = {
    "distributed.worker.memory.target": False,
    "distributed.worker.memory.spill": False,
    "distributed.worker.memory.pause": False,
    "distributed.worker.memory.terminate": 0.95,
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
}

# One task thread per worker, and OpenMP, BLAS and XLA's Eigen kernels without thread pools of
# their own (XLA's CPU runtime still runs independent parts of a program in parallel; pinning a
# worker to one core to stop that cost more wall time than it saved: README, fleet runs).
_WORKER_ENV = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "JAX_ENABLE_X64": "1",
    "JAX_PLATFORMS": "cpu",
}
_WORKER_XLA_FLAGS = "--xla_cpu_multi_thread_eigen=false"


def _worker_env() -> dict[str, str]:
    """The local workers' environment: :data:`_WORKER_ENV`, and XLA_FLAGS that start with the
    one-thread flag and go on with this process's own, so that a dump folder or a code generator
    chosen for the run reaches the workers too (and wins where both name a flag: XLA reads the
    last). Idempotent: flags that already start with the one-thread flag are kept as they are,
    so that a process started with a worker's environment gives its workers the same flags (they
    are part of JAX's compilation-cache key, and a repeated flag would change it)."""
    own = os.environ.get("XLA_FLAGS", "").strip()
    if own.split()[:1] == [_WORKER_XLA_FLAGS]:
        return {**_WORKER_ENV, "XLA_FLAGS": own}
    return {**_WORKER_ENV, "XLA_FLAGS": f"{_WORKER_XLA_FLAGS} {own}".strip()}


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None, memory_limit=None):
    """A dask ``Client``: on the cluster at ``scheduler``, or on a new ``LocalCluster``.

    The local cluster has ``workers`` processes (default: one per core), each with one task thread
    and ``memory_limit`` (default :data:`DEFAULT_MEMORY_LIMIT`). With an address the cluster's
    own workers run the tasks (dask-jobqueue, Kubernetes, cloud: the same code). Either way the
    workers import the package before their first task (:class:`.worker_plugin.ImportTasks`).
    The local workers ignore SIGINT (:class:`.worker_plugin.IgnoreCtrlC`): Ctrl-C stops the
    client, which closes them.

    Raises
    ------
    BadInputError
        No scheduler answers at ``scheduler`` (within dask's connect timeout,
        ``distributed.comm.timeouts.connect``), or its workers cannot import the package.
    """
    import dask
    from distributed import Client, LocalCluster

    from .worker_plugin import IgnoreCtrlC, ImportTasks

    if scheduler:
        try:
            client = Client(scheduler)
        except (OSError, ValueError) as err:  # unreachable (a timeout is an OSError), malformed
            raise BadInputError(
                f"scheduler: expected a reachable dask scheduler, got {scheduler!r} "
                f"({_first_line(err)})"
            ) from None
        with client:
            _register_import_tasks(client, scheduler)
            yield client
        return
    n = workers or os.cpu_count() or 1
    with (
        dask.config.set(_WORKER_MEMORY_CONFIG),
        LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            memory_limit=memory_limit or DEFAULT_MEMORY_LIMIT,
            dashboard_address=":0",  # any free port: two runs on one machine must not clash
            env=_worker_env(),
        ) as cluster,
        Client(cluster) as client,
    ):
        client.register_plugin(IgnoreCtrlC())
        client.register_plugin(ImportTasks())
        try:
            yield client
        except BaseException:
            if _interrupts.pending() is not None:
                _quiet_workers(client)
            raise


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


def _register_import_tasks(client, scheduler: str) -> None:
    """:class:`.worker_plugin.ImportTasks` on a cluster at an address, whose workers were
    started elsewhere: one that cannot import the package (another environment) fails here, in
    one line, not in every task."""
    from .worker_plugin import ImportTasks

    try:
        client.register_plugin(ImportTasks())
    except Exception as err:  # noqa: BLE001 -- the worker's own error, whatever it is
        raise BadInputError(
            f"scheduler {scheduler}: expected workers that import tyrebayes (the same "
            f"environment as this client), got {type(err).__name__}: {_first_line(err)}"
        ) from None


def _quiet_workers(client) -> None:
    """Before a local cluster closes on a signal: its workers' warnings about the tasks the
    closing cancels would print around the command's one line."""

    def quiet() -> None:
        import logging

        logging.getLogger("distributed").setLevel(logging.CRITICAL + 1)

    with contextlib.suppress(Exception):
        client.run(quiet, on_error="ignore")


class _Progress:
    """tqdm on stderr when it is a terminal; silent otherwise (logs, pipes, tests)."""

    def __init__(self, total: int, enabled: bool | None):
        self.bar = None
        if enabled is None:
            enabled = sys.stderr.isatty()
        if enabled:
            from tqdm import tqdm

            self.bar = tqdm(total=total, file=sys.stderr, unit="item", desc="fleet-run")

    def update(self, label: str) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(label[:40], refresh=False)
            self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _task_slots(slots: dict[str, int]) -> int:
    """The cluster's task threads (at least 1), from its workers' threads: the tasks it runs at
    once."""
    return max(1, sum(slots.values()))


def _stage_stats(records: list[dict]) -> dict:
    """Counts and costs of one stage: ``done`` (ran now and succeeded), ``skipped`` (an earlier
    record was reused, whatever its status), ``failed`` (failed now or earlier: still failed),
    ``failed_now``; seconds, CPU seconds, peak RSS and the number that started by dropping
    their worker's compiled programs (:mod:`.worker_memory`) over the items that ran now."""
    ran = [r for r in records if not r.get("skipped")]
    return {
        "items": len(records),
        "done": sum(r.get("status") == "done" for r in ran),
        "skipped": len(records) - len(ran),
        "failed": sum(r.get("status") == "failed" for r in records),
        "failed_now": sum(r.get("status") == "failed" for r in ran),
        "seconds": sum(float(r.get("seconds", 0.0)) for r in ran),
        "cpu_seconds": sum(float(r.get("cpu_seconds", 0.0)) for r in ran),
        "peak_rss_mb_max": max((float(r.get("peak_rss_mb", 0.0)) for r in ran), default=0.0),
        "programs_dropped": sum(bool(r.get("programs_dropped")) for r in ran),
    }


def _write_tables(
    out: Path, drive_records: list[dict], set_records: list[dict]
) -> tuple[pd.DataFrame, list[str]]:
    drives_dir = out / DRIVES_DIR
    # drive_order: the position in the manifest, which fit-wear reads as a car's drive order.
    summaries = [
        pd.read_parquet(drives_dir / f"{r['drive_id']}.summary.parquet").assign(drive_order=k)
        for k, r in enumerate(drive_records)
        if r.get("status") == "done"
    ]
    written = []
    if summaries:
        write_parquet(pd.concat(summaries, ignore_index=True), out / "drive_summaries.parquet")
        written.append("drive_summaries")
    sets = tyre_set_table(str(out), set_records)
    if len(sets):
        # An empty table (every set failed) would replace the last run's results with nothing.
        write_parquet(sets, out / "tyre_sets.parquet")
        written.append("tyre_sets")
    failures = [
        {"item": "drive", "id": r["drive_id"], "path": r.get("path", ""), "reason": r["reason"]}
        for r in drive_records
        if r.get("status") == "failed"
    ] + [
        {"item": "tyre_set", "id": r["tyre_set_id"], "path": "", "reason": r["reason"]}
        for r in set_records
        if r.get("status") == "failed"
    ]
    table = pd.DataFrame(failures, columns=["item", "id", "path", "reason"])
    atomic_write_bytes(out / "failures.csv", table.to_csv(index=False).encode())
    return sets, written


def run_outcome(drives: list[dict], sets: list[dict], fleet: dict) -> str:
    """``"ok"`` (every item done, now or before), ``"failures"`` (some drive, tyre set or the
    fleet model failed; the rest stands) or ``"nothing_usable"`` (no tyre set has a fit).

    ``fleet-run`` exits 0, 4 and 2 for them.
    """
    if not any(r.get("status") == "done" for r in sets):
        return "nothing_usable"
    records = [*drives, *sets, fleet]
    return "failures" if any(r.get("status") == "failed" for r in records) else "ok"


def prepare_out(out: str | os.PathLike) -> Path:
    """Make the output folder and its stage folders; refuse a file where one belongs.

    Checked before a cluster starts: a file named ``drives`` in ``out`` failed every drive on
    the workers, with their tracebacks, where one line says it.

    Raises
    ------
    BadInputError
        ``out`` or one of its stage folders exists and is not a folder.
    """
    out = Path(out)
    for folder in (out, out / DRIVES_DIR, out / TYRE_SETS_DIR, out / FLEET_DIR):
        if folder.exists() and not folder.is_dir():
            raise BadInputError(
                f"--out: expected {folder} to be a folder (or not to exist), got a file"
            )
    for folder in (out / DRIVES_DIR, out / TYRE_SETS_DIR, out / FLEET_DIR):
        folder.mkdir(parents=True, exist_ok=True)
    return out


def sweep_run_temporaries(out: str | os.PathLike) -> list[Path]:
    """Remove the temporary files that workers killed in the middle of a write left in ``out``.

    For a local cluster, after it closed (its workers' PIDs are this host's). A remote
    cluster's writers are not this host's processes: leave theirs to the next writer.
    """
    out = Path(out)
    removed = []
    for folder in (out, out / DRIVES_DIR, out / TYRE_SETS_DIR, out / FLEET_DIR):
        removed += sweep_folder_temporaries(folder)
    return removed


def fleet_run(
    items: list[DriveItem],
    out: str | os.PathLike,
    client,
    settings: RunSettings | None = None,
    *,
    progress: bool | None = None,
) -> dict:
    """Run the three stages over ``items`` on a dask ``client``; returns the run's summary.

    Parameters
    ----------
    items : list of DriveItem
        From :func:`~.manifest.read_manifest`.
    out : path-like
        Output folder (created); a rerun into the same folder skips unchanged items.
    client : distributed.Client
        From :func:`dask_client` (or any client).
    settings : RunSettings, optional
        Default :class:`RunSettings` (fast fits).
    progress : bool, optional
        Progress bar on stderr; default: when stderr is a terminal.

    Returns
    -------
    dict
        Written to ``out/summary.json`` too: ``drives``, ``tyre_sets``, ``fleet`` (per stage:
        items, done, skipped, failed, seconds and CPU seconds summed over the items, the largest
        worker peak RSS), ``failures`` (id and one-line reason), ``wall_seconds``,
        ``workers``, ``settings``, ``drive_hours`` (processed this run), ``outputs``,
        ``written`` (the tables this run replaced) and ``outcome`` (:func:`run_outcome`).

    Raises
    ------
    BadInputError
        A file where ``out`` or one of its stage folders belongs (:func:`prepare_out`).
    tyrebayes._interrupts.Interrupted
        A signal (in the command line): the items in flight are not recorded, no table written.
    """
    from distributed import as_completed

    settings = settings or RunSettings()
    start = time.perf_counter()
    out = prepare_out(out)
    out_s = str(out.resolve())
    by_set: dict[str, list[DriveItem]] = defaultdict(list)
    for item in items:
        by_set[item.tyre_set_id].append(item)
    set_type = {
        s: next((d.tyre_type for d in drives if d.tyre_type), "") for s, drives in by_set.items()
    }
    bar = _Progress(len(items) + len(by_set), progress)
    futures = {
        client.submit(
            process_drive, item, out_s, settings, key=f"drive-{item.drive_id}", pure=False
        ): ("drive", item)
        for item in items
    }
    drive_records: dict[str, dict] = {}
    set_records: dict[str, dict] = {}
    completed = as_completed(list(futures))

    ready_sets: list[str] = []
    drives_left = len(items)
    # Padded windows of fits sent to each worker, and the worker last sent each padded size.
    placed: dict[str, float] = defaultdict(float)
    shape_worker: dict[int, str] = {}

    def release_sets() -> None:
        # Ready sets wait here, not in the workers, until the drive stage's tail: a task sent
        # to a worker waits in that worker's own queue, where it goes before the drives the
        # scheduler has not sent yet, whatever its priority. Sent early, fits and drives
        # alternated, and each fit at a new shape dropped the worker's programs, the drive
        # stage's with them: a 1-worker run of 200 drives dropped them at 48 tasks and took
        # 1.9 times the CPU seconds of the same work in a warm plain loop (the fleet_run
        # benchmark). Sent together, the largest padded shape
        # first, the longest fits start first, and each worker is given the sets of a few
        # shapes (place_sets) and meets each of them once.
        if not ready_sets:
            return
        slots = client.nthreads()  # worker address → task threads, now
        if drives_left > _task_slots(slots):
            return
        finished = {
            s: [
                drive_records[d.drive_id]
                for d in by_set[s]
                if drive_records[d.drive_id].get("status") == "done"
            ]
            for s in ready_sets
        }
        # The padded number of windows of each set's fit, from its finished drives.
        size = {s: pad_size(sum(r["windows"] for r in drives)) for s, drives in finished.items()}
        # No worker at the moment (all lost, or not yet joined): the scheduler places them.
        worker = place_sets(size, slots, placed, shape_worker) if slots else {}
        for s in sorted(ready_sets, key=size.get, reverse=True):
            submit_set(s, finished[s], size[s], worker.get(s))
            if s in worker:
                placed[worker[s]] += size[s]
                shape_worker[size[s]] = worker[s]
        ready_sets.clear()

    def submit_set(s: str, finished: list[dict], size: int, worker: str | None) -> None:
        # A loose restriction: an idle worker still takes the set, and a lost worker's runs
        # elsewhere.
        fut = client.submit(
            fit_tyre_set,
            s,
            set_type[s],
            finished,
            out_s,
            settings,
            key=f"tyre-set-{set_file_name(s)}",
            pure=False,
            priority=size - _SET_PRIORITY_OFFSET,
            workers=[worker] if worker else None,
            allow_other_workers=bool(worker),
        )
        futures[fut] = ("tyre_set", s)
        completed.add(fut)

    for future in completed:
        kind, item = futures.pop(future)
        try:
            record = future.result()
        except Exception as err:  # noqa: BLE001 -- a lost worker or a bug: recorded, run goes on
            # After a signal the cluster is being torn down under its tasks: their errors are
            # the interruption's, and an item left without a record runs again next time.
            _interrupts.check()
            from .drive_stage import one_line

            name = item.drive_id if kind == "drive" else item
            record = {"status": "failed", "reason": f"task failed: {one_line(err)}"}
            record |= {"drive_id": name, "path": item.path} if kind == "drive" else {}
            record |= {"tyre_set_id": item} if kind == "tyre_set" else {}
        future.release()
        if kind == "drive":
            drive_records[item.drive_id] = record
            drives_left -= 1
            bar.update(item.drive_id)
            if all(d.drive_id in drive_records for d in by_set[item.tyre_set_id]):
                ready_sets.append(item.tyre_set_id)
            release_sets()
        else:
            set_records[item] = record
            bar.update(f"set {item}")
    bar.close()
    _interrupts.check()  # swallowed on the way (a dask callback): no tables from a cut run
    ordered_drives = [drive_records[i.drive_id] for i in items]
    ordered_sets = [set_records[s] for s in by_set]
    sets, written = _write_tables(out, ordered_drives, ordered_sets)
    fleet_record = run_fleet_stage(out_s, sets, settings)
    processed = [r for r in ordered_drives if r.get("status") == "done" and not r.get("skipped")]
    summary = {
        "drives": _stage_stats(ordered_drives),
        "tyre_sets": _stage_stats(ordered_sets),
        "fleet": {
            "status": fleet_record.get("status"),
            "skipped": bool(fleet_record.get("skipped")),
            "reason": fleet_record.get("reason", ""),
            "rows": fleet_record.get("rows", 0),
            "seconds": float(fleet_record.get("seconds", 0.0)),
        },
        "failures": [
            {"item": "drive", "id": r["drive_id"], "reason": r["reason"]}
            for r in ordered_drives
            if r.get("status") == "failed"
        ]
        + [
            {"item": "tyre_set", "id": r["tyre_set_id"], "reason": r["reason"]}
            for r in ordered_sets
            if r.get("status") == "failed"
        ]
        + (
            [{"item": "fleet", "id": "fleet", "reason": fleet_record.get("reason", "")}]
            if fleet_record.get("status") == "failed"
            else []
        ),
        "drive_hours": sum(float(r.get("duration_s", 0.0)) for r in processed) / 3600.0,
        "wall_seconds": time.perf_counter() - start,
        "workers": len(client.scheduler_info().get("workers", {})),
        "client_peak_rss_mb": peak_rss_mb(),
        "settings": {
            "method": settings.method,
            "model": settings.model,
            "seed": settings.seed,
            "window_s": settings.window_s,
        },
        "outputs": {
            "drive_summaries": "drive_summaries.parquet",
            "tyre_sets": "tyre_sets.parquet",
            "failures": "failures.csv",
            "fleet": "fleet/",
        },
        # The tables this run wrote; one left out kept the last run's (no rows this time).
        "written": [*written, "failures"],
        "outcome": run_outcome(ordered_drives, ordered_sets, fleet_record),
    }
    atomic_write_bytes(
        out / "summary.json", (json.dumps(to_jsonable(summary), indent=1) + "\n").encode()
    )
    return summary
