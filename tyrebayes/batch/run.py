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
rows gathered: :func:`~.run_folder.write_tables`), ``failures.csv`` (item, id, path, one-line
reason), ``fleet/`` and ``summary.json`` (:func:`fleet_run`'s
:class:`~.run_result.FleetRunResult`). A gathered table replaces the previous one only when the
run has rows for it: a run in which every tyre set failed leaves the last ``tyre_sets.parquet``
as it was (the summary says it was not written).

An interruption (SIGINT, SIGTERM: :mod:`tyrebayes._interrupts`) ends the run without recording
the items in flight: they have no record and run again next time, and the tables are not
written. A local cluster's workers ignore Ctrl-C (it reaches the terminal's whole process
group): the client stops them when it closes the cluster.
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections import defaultdict

from .. import _interrupts
from .._io import atomic_write_bytes, to_jsonable
from .drive_stage import one_line, process_drive
from .fleet_stage import run_fleet_stage
from .manifest import DriveItem
from .placement import place_sets
from .run_folder import prepare_out, write_tables
from .run_result import FleetRunResult
from .settings import RunSettings
from .tyre_set_stage import fit_tyre_set, pad_size, set_file_name, tyre_set_table
from .worker_memory import peak_rss_mb

# Tyre-set tasks' priorities are their padded shape minus this: below every drive task's 0.
_SET_PRIORITY_OFFSET = 1 << 40


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


class _StageRun:
    """The drive and tyre-set stages of one run, on the client: the tasks in flight, the records
    gathered, the tyre sets that are ready and held back.

    A set is ready once its drives have finished (done, failed or skipped); ready sets are held
    here until the drives still to finish are no more than the cluster's task slots
    (:meth:`release_sets`).
    """

    def __init__(self, items: list[DriveItem], out: str, client, settings: RunSettings):
        self.items, self.out, self.client, self.settings = items, out, client, settings
        self.by_set: dict[str, list[DriveItem]] = defaultdict(list)
        for item in items:
            self.by_set[item.tyre_set_id].append(item)
        # A set's tyre type: the first of its drives that names one.
        self.set_type = {
            s: next((d.tyre_type for d in drives if d.tyre_type), "")
            for s, drives in self.by_set.items()
        }
        self.futures: dict = {}
        self.drive_records: dict[str, dict] = {}
        self.set_records: dict[str, dict] = {}
        self.ready_sets: list[str] = []
        self.drives_left = len(items)
        # Padded windows of fits sent to each worker, and the worker last sent each padded size.
        self.placed: dict[str, float] = defaultdict(float)
        self.shape_worker: dict[int, str] = {}
        self.completed = None

    def run(self, progress: bool | None) -> None:
        """Submit every drive, then gather each finished task's record, releasing the tyre sets
        as their drives finish, until every drive and set has its record."""
        from distributed import as_completed

        bar = _Progress(len(self.items) + len(self.by_set), progress)
        for item in self.items:
            future = self.client.submit(
                process_drive,
                item,
                self.out,
                self.settings,
                key=f"drive-{item.drive_id}",
                pure=False,
            )
            self.futures[future] = ("drive", item)
        self.completed = as_completed(list(self.futures))
        for future in self.completed:
            stage, item = self.futures.pop(future)
            record = _task_record(future, stage, item)
            future.release()
            if stage == "drive":
                self.drive_finished(item, record)
                bar.update(item.drive_id)
            else:
                self.set_records[item] = record
                bar.update(f"set {item}")
        bar.close()

    def drive_finished(self, item: DriveItem, record: dict) -> None:
        """Keep a drive's record; its set is ready when its last drive finished."""
        self.drive_records[item.drive_id] = record
        self.drives_left -= 1
        if all(d.drive_id in self.drive_records for d in self.by_set[item.tyre_set_id]):
            self.ready_sets.append(item.tyre_set_id)
        self.release_sets()

    def release_sets(self) -> None:
        """Submit the ready sets once the drive stage is in its tail, each to a worker
        (:func:`~.placement.place_sets`), the largest padded shape first."""
        # Ready sets wait here, not in the workers, until the drive stage's tail: a task sent
        # to a worker waits in that worker's own queue, where it goes before the drives the
        # scheduler has not sent yet, whatever its priority. Sent early, fits and drives
        # alternated, and each fit at a new shape dropped the worker's programs, the drive
        # stage's with them: a 1-worker run of 200 drives dropped them at 48 tasks and took
        # 1.9 times the CPU seconds of the same work in a warm plain loop (the fleet_run
        # benchmark). Sent together, the largest padded shape
        # first, the longest fits start first, and each worker is given the sets of a few
        # shapes (place_sets) and meets each of them once.
        if not self.ready_sets:
            return
        slots = self.client.nthreads()  # worker address → task threads, now
        if self.drives_left > _task_slots(slots):
            return
        finished = {s: self.finished_drives(s) for s in self.ready_sets}
        # The padded number of windows of each set's fit, from its finished drives.
        size = {s: pad_size(sum(r["windows"] for r in drives)) for s, drives in finished.items()}
        # No worker at the moment (all lost, or not yet joined): the scheduler places them.
        worker = place_sets(size, slots, self.placed, self.shape_worker) if slots else {}
        for s in sorted(self.ready_sets, key=size.get, reverse=True):
            self.submit_set(s, finished[s], size[s], worker.get(s))
            if s in worker:
                self.placed[worker[s]] += size[s]
                self.shape_worker[size[s]] = worker[s]
        self.ready_sets.clear()

    def finished_drives(self, tyre_set_id: str) -> list[dict]:
        """The records of a set's drives that are done (the ones its fit reads)."""
        records = (self.drive_records[d.drive_id] for d in self.by_set[tyre_set_id])
        return [r for r in records if r.get("status") == "done"]

    def submit_set(self, s: str, finished: list[dict], size: int, worker: str | None) -> None:
        """Submit one set's fit, below every drive's priority, larger shapes first."""
        # A loose restriction: an idle worker still takes the set, and a lost worker's runs
        # elsewhere.
        fut = self.client.submit(
            fit_tyre_set,
            s,
            self.set_type[s],
            finished,
            self.out,
            self.settings,
            key=f"tyre-set-{set_file_name(s)}",
            pure=False,
            priority=size - _SET_PRIORITY_OFFSET,
            workers=[worker] if worker else None,
            allow_other_workers=bool(worker),
        )
        self.futures[fut] = ("tyre_set", s)
        self.completed.add(fut)

    def ordered_records(self) -> tuple[list[dict], list[dict]]:
        """The drives' records in manifest order, and the sets' in order of first appearance."""
        drives = [self.drive_records[i.drive_id] for i in self.items]
        return drives, [self.set_records[s] for s in self.by_set]


def _task_record(future, stage: str, item) -> dict:
    """A finished task's record, or a failed one when the task raised (a lost worker, a bug):
    recorded, and the run goes on."""
    try:
        return future.result()
    except Exception as err:  # noqa: BLE001 -- a lost worker or a bug: recorded, run goes on
        # After a signal the cluster is being torn down under its tasks: their errors are
        # the interruption's, and an item left without a record runs again next time.
        _interrupts.check()
        record = {"status": "failed", "reason": f"task failed: {one_line(err)}"}
        if stage == "drive":
            return record | {"drive_id": item.drive_id, "path": item.path}
        return record | {"tyre_set_id": item}


def fleet_run(
    items: list[DriveItem],
    out: str | os.PathLike,
    client,
    settings: RunSettings | None = None,
    *,
    progress: bool | None = None,
) -> FleetRunResult:
    """Run the three stages over ``items`` on a dask ``client``; returns the run's summary.

    Parameters
    ----------
    items : list of DriveItem
        From :func:`~.manifest.read_manifest`.
    out : path-like
        Output folder (created); a rerun into the same folder skips unchanged items.
    client : distributed.Client
        From :func:`~.cluster.dask_client` (or any client).
    settings : RunSettings, optional
        Default :class:`RunSettings` (fast fits).
    progress : bool, optional
        Progress bar on stderr; default: when stderr is a terminal.

    Returns
    -------
    FleetRunResult
        Per stage: items, done, skipped, failed, seconds and CPU seconds summed over the items,
        the largest worker peak RSS; the failures (id and one-line reason), wall seconds,
        workers, settings, drive-hours processed this run, the tables written and the outcome
        (:func:`~.run_result.run_outcome`). Its ``to_dict()`` is written to
        ``out/summary.json`` too.

    Raises
    ------
    BadInputError
        A file where ``out`` or one of its stage folders belongs
        (:func:`~.run_folder.prepare_out`).
    tyrebayes._interrupts.Interrupted
        A signal (in the command line): the items in flight are not recorded, no table written.

    Examples
    --------
    A run needs logs and minutes of fits, so this example is not run as a test.

    >>> import tyrebayes as tb
    >>> with tb.dask_client(workers=2) as client:  # doctest: +SKIP
    ...     result = tb.fleet_run(tb.read_manifest("manifest.csv"), "fleet_out", client)
    >>> result.outcome in ("ok", "failures", "nothing_usable")  # doctest: +SKIP
    True
    >>> sorted(result.to_dict())[:3]  # the JSON of summary.json  # doctest: +SKIP
    ['client_peak_rss_mb', 'drive_hours', 'drives']
    """
    settings = settings or RunSettings()
    start = time.perf_counter()
    out = prepare_out(out)
    out_s = str(out.resolve())
    stages = _StageRun(items, out_s, client, settings)
    stages.run(progress)
    _interrupts.check()  # swallowed on the way (a dask callback): no tables from a cut run
    drive_records, set_records = stages.ordered_records()
    sets = tyre_set_table(out_s, set_records)
    written = write_tables(out, drive_records, set_records, sets)
    fleet_record = run_fleet_stage(out_s, sets, settings)
    result = FleetRunResult.from_records(
        drive_records,
        set_records,
        fleet_record,
        written,
        wall_seconds=time.perf_counter() - start,
        workers=len(client.scheduler_info().get("workers", {})),
        client_peak_rss_mb=peak_rss_mb(),
        settings=settings,
    )
    summary = json.dumps(to_jsonable(result.to_dict()), indent=1) + "\n"
    atomic_write_bytes(out / "summary.json", summary.encode())
    return result
