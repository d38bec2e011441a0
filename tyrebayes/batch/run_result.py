"""What a fleet run returns (:func:`~.run.fleet_run`): per-stage counts, failures, cost, outcome.

:class:`FleetRunResult` is made from the run's records (:meth:`FleetRunResult.from_records`);
its :meth:`~FleetRunResult.to_dict` is ``summary.json`` and ``tyrebayes fleet-run --json``.
"""

from __future__ import annotations

import dataclasses

from .settings import RunSettings

#: The gathered outputs of a run, relative to its folder.
RUN_OUTPUTS = {
    "drive_summaries": "drive_summaries.parquet",
    "tyre_sets": "tyre_sets.parquet",
    "failures": "failures.csv",
    "fleet": "fleet/",
}


def run_outcome(drives: list[dict], sets: list[dict], fleet: dict) -> str:
    """``"ok"`` (every item done, now or before), ``"failures"`` (some drive, tyre set or the
    fleet model failed; the rest stands) or ``"nothing_usable"`` (no tyre set has a fit).

    ``fleet-run`` exits 0, 4 and 2 for them.

    Examples
    --------
    >>> run_outcome([{"status": "done"}], [{"status": "done"}], {"status": "failed"})
    'failures'
    """
    if not any(r.get("status") == "done" for r in sets):
        return "nothing_usable"
    records = [*drives, *sets, fleet]
    return "failures" if any(r.get("status") == "failed" for r in records) else "ok"


@dataclasses.dataclass(frozen=True)
class StageStats:
    """Counts and costs of one stage of a fleet run (drives, or tyre sets).

    Attributes
    ----------
    items : int
        Items of the stage.
    done : int
        Ran now and succeeded.
    skipped : int
        An earlier record was reused, whatever its status.
    failed : int
        Failed now or earlier (still failed).
    failed_now : int
        Failed in this run.
    seconds : float
        Task seconds summed over the items that ran now [s].
    cpu_seconds : float
        CPU seconds summed over the items that ran now [s].
    peak_rss_mb_max : float
        The largest worker peak resident memory of the items that ran now [MB].
    programs_dropped : int
        Items that ran now and started by dropping their worker's compiled programs
        (:mod:`.worker_memory`).

    Examples
    --------
    >>> s = StageStats.from_records([{"status": "done", "seconds": 2.0}, {"skipped": True}])
    >>> s.done, s.skipped, s.seconds
    (1, 1, 2.0)
    """

    items: int
    done: int
    skipped: int
    failed: int
    failed_now: int
    seconds: float
    cpu_seconds: float
    peak_rss_mb_max: float
    programs_dropped: int

    @classmethod
    def from_records(cls, records: list[dict]) -> StageStats:
        """The stage's counts from its items' records (those of this run and reused ones)."""
        ran = [r for r in records if not r.get("skipped")]
        return cls(
            items=len(records),
            done=sum(r.get("status") == "done" for r in ran),
            skipped=len(records) - len(ran),
            failed=sum(r.get("status") == "failed" for r in records),
            failed_now=sum(r.get("status") == "failed" for r in ran),
            # Started at 0.0: a float when no item ran too.
            seconds=sum((float(r.get("seconds", 0.0)) for r in ran), 0.0),
            cpu_seconds=sum((float(r.get("cpu_seconds", 0.0)) for r in ran), 0.0),
            peak_rss_mb_max=max((float(r.get("peak_rss_mb", 0.0)) for r in ran), default=0.0),
            programs_dropped=sum(bool(r.get("programs_dropped")) for r in ran),
        )

    def to_dict(self) -> dict:
        """The fields as a dict, in order (a stage's object in ``summary.json``)."""
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class FleetStageStats:
    """The fleet stage of a run (:func:`~.fleet_stage.run_fleet_stage`).

    Attributes
    ----------
    status : str or None
        ``"done"`` or ``"failed"`` (None when the stage wrote no status).
    skipped : bool
        Its earlier record was reused (its inputs had not changed).
    reason : str
        One line: why it failed or what it left out ("" when nothing).
    rows : int
        Tyre sets in the fleet table.
    seconds : float
        Time of the stage when it ran now [s].

    Examples
    --------
    >>> FleetStageStats.from_record({"status": "done", "rows": 3}).to_dict()["rows"]
    3
    """

    status: str | None
    skipped: bool
    reason: str
    rows: int
    seconds: float

    @classmethod
    def from_record(cls, record: dict) -> FleetStageStats:
        """The stage from its record."""
        return cls(
            status=record.get("status"),
            skipped=bool(record.get("skipped")),
            reason=record.get("reason", ""),
            rows=record.get("rows", 0),
            seconds=float(record.get("seconds", 0.0)),
        )

    def to_dict(self) -> dict:
        """The fields as a dict, in order (``summary.json``'s ``"fleet"``)."""
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class RunFailure:
    """One failed item of a run.

    Attributes
    ----------
    item : str
        ``"drive"``, ``"tyre_set"`` or ``"fleet"``.
    item_id : str
        The drive's or tyre set's id (``"fleet"`` for the fleet model).
    reason : str
        One line.

    Examples
    --------
    >>> RunFailure("drive", "d1", "no such file").to_dict()
    {'item': 'drive', 'id': 'd1', 'reason': 'no such file'}
    """

    item: str
    item_id: str
    reason: str

    def to_dict(self) -> dict:
        """``{"item", "id", "reason"}`` (an entry of ``summary.json``'s ``"failures"``)."""
        return {"item": self.item, "id": self.item_id, "reason": self.reason}


def _run_failures(drives: list[dict], sets: list[dict], fleet: dict) -> tuple[RunFailure, ...]:
    """The failed items of a run, drives then tyre sets (in their order) then the fleet model.

    Examples
    --------
    >>> _run_failures([{"status": "failed", "drive_id": "d", "reason": "r"}], [], {})
    (RunFailure(item='drive', item_id='d', reason='r'),)
    """
    failed = [RunFailure("drive", r["drive_id"], r["reason"]) for r in drives if _failed(r)]
    failed += [RunFailure("tyre_set", r["tyre_set_id"], r["reason"]) for r in sets if _failed(r)]
    if _failed(fleet):
        failed.append(RunFailure("fleet", "fleet", fleet.get("reason", "")))
    return tuple(failed)


def _failed(record: dict) -> bool:
    return record.get("status") == "failed"


@dataclasses.dataclass(frozen=True)
class FleetRunResult:
    """The summary of a fleet run (:func:`~.run.fleet_run`), also in ``out/summary.json``.

    Attributes
    ----------
    drives : StageStats
        The drive stage.
    tyre_sets : StageStats
        The tyre-set stage.
    fleet : FleetStageStats
        The fleet stage.
    failures : tuple of RunFailure
        Every failed item, with its one-line reason (also in ``failures.csv``).
    drive_hours : float
        Hours of driving processed in this run (drives skipped as unchanged left out) [h].
    wall_seconds : float
        Wall time of the run, cluster start-up excluded [s].
    workers : int
        Workers of the cluster at the end of the run.
    client_peak_rss_mb : float
        Peak resident memory of the client process [MB].
    settings : RunSettings
        The run's settings (``to_dict`` keeps ``method``, ``model``, ``seed``, ``window_s``).
    written : tuple of str
        The tables this run wrote; one left out kept the last run's (it had no rows this time).
    outcome : str
        ``"ok"``, ``"failures"`` or ``"nothing_usable"`` (:func:`run_outcome`).

    Examples
    --------
    >>> drives = [{"status": "done", "drive_id": "d1", "duration_s": 1800.0, "seconds": 4.0},
    ...           {"status": "failed", "drive_id": "d2", "reason": "corrupt file"}]
    >>> sets = [{"status": "done", "tyre_set_id": "s1", "seconds": 9.0}]
    >>> result = FleetRunResult.from_records(
    ...     drives, sets, {"status": "done", "rows": 1}, ["tyre_sets"],
    ...     wall_seconds=20.0, workers=2, client_peak_rss_mb=300.0, settings=RunSettings())
    >>> result.outcome, result.drive_hours, result.drives.failed
    ('failures', 0.5, 1)
    >>> result.to_dict()["failures"]
    [{'item': 'drive', 'id': 'd2', 'reason': 'corrupt file'}]
    >>> result.to_dict()["written"]
    ['tyre_sets', 'failures']
    """

    drives: StageStats
    tyre_sets: StageStats
    fleet: FleetStageStats
    failures: tuple[RunFailure, ...]
    drive_hours: float
    wall_seconds: float
    workers: int
    client_peak_rss_mb: float
    settings: RunSettings
    written: tuple[str, ...]
    outcome: str

    @classmethod
    def from_records(
        cls,
        drives: list[dict],
        sets: list[dict],
        fleet: dict,
        written: list[str],
        *,
        wall_seconds: float,
        workers: int,
        client_peak_rss_mb: float,
        settings: RunSettings,
    ) -> FleetRunResult:
        """The result from the run's records, in manifest order, and what the run measured.

        ``written`` names the tables the run replaced besides ``failures.csv``, which every run
        writes.
        """
        processed = [r for r in drives if r.get("status") == "done" and not r.get("skipped")]
        return cls(
            drives=StageStats.from_records(drives),
            tyre_sets=StageStats.from_records(sets),
            fleet=FleetStageStats.from_record(fleet),
            failures=_run_failures(drives, sets, fleet),
            drive_hours=sum(float(r.get("duration_s", 0.0)) for r in processed) / 3600.0,
            wall_seconds=wall_seconds,
            workers=workers,
            client_peak_rss_mb=client_peak_rss_mb,
            settings=settings,
            written=(*written, "failures"),
            outcome=run_outcome(drives, sets, fleet),
        )

    def to_dict(self) -> dict:
        """The summary as ``summary.json`` and ``tyrebayes fleet-run --json`` give it."""
        return {
            "drives": self.drives.to_dict(),
            "tyre_sets": self.tyre_sets.to_dict(),
            "fleet": self.fleet.to_dict(),
            "failures": [f.to_dict() for f in self.failures],
            "drive_hours": self.drive_hours,
            "wall_seconds": self.wall_seconds,
            "workers": self.workers,
            "client_peak_rss_mb": self.client_peak_rss_mb,
            "settings": {
                "method": self.settings.method,
                "model": self.settings.model,
                "seed": self.settings.seed,
                "window_s": self.settings.window_s,
            },
            "outputs": dict(RUN_OUTPUTS),
            "written": list(self.written),
            "outcome": self.outcome,
        }
