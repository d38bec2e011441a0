"""A fleet run's output folder: its stage folders, its gathered tables, its clean-up.

The layout: ``drives/``, ``tyre_sets/`` and ``fleet/`` (the stages' own outputs and records),
``drive_summaries.parquet``, ``tyre_sets.parquet`` and ``failures.csv`` (gathered by
:func:`write_tables` at the end of a run) and ``summary.json``.
"""

from __future__ import annotations

import os
from pathlib import Path

import pandas as pd

from .._errors import BadInputError
from .._io import atomic_write_bytes, sweep_folder_temporaries
from .drive_stage import DRIVES_DIR
from .fleet_stage import FLEET_DIR
from .records import write_parquet
from .tyre_set_stage import TYRE_SETS_DIR


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


def write_tables(
    out: Path, drive_records: list[dict], set_records: list[dict], sets: pd.DataFrame
) -> list[str]:
    """Gather the run's tables into ``out``: ``drive_summaries.parquet`` (the drives done, with
    ``drive_order``), ``tyre_sets.parquet`` (``sets``, from :func:`~.tyre_set_stage.tyre_set_table`,
    when it has rows) and ``failures.csv``.

    Returns the names of the tables written besides ``failures``.
    """
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
    return written
