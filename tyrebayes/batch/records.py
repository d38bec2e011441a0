"""Item records of a fleet run: content hashes, settings, atomic table writes, skip decisions.

Every item (a drive, a tyre set, the fleet) writes its outputs first and then its record,
``NAME.record.json`` beside them, atomically: ``{"status": "done" | "failed", "input_hash",
"settings", "reason", "outputs", "seconds", ...}``. A rerun skips an item whose record carries the
same input hash and settings (a failed one too: a corrupt file stays corrupt); an item killed
before its record was written has no record and runs again, its half-written temporary files
swept by the next writer (:mod:`tyrebayes._io`). So does an item stopped by an interruption:
a failure while the process or its worker is being stopped (:func:`stopping`) is the
interruption's, not the item's, and is never recorded.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from pathlib import Path

import pandas as pd

from .. import _interrupts
from .._io import atomic_output, atomic_write_bytes, to_jsonable

_CHUNK = 1 << 20


def file_hash(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes (hex); what makes a rerun skip an unchanged log."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(_CHUNK):
            digest.update(block)
    return digest.hexdigest()


def value_hash(value) -> str:
    """SHA-256 of a JSON-ready value in canonical form (sorted keys)."""
    text = json.dumps(to_jsonable(value), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def record_path(folder: Path, name: str) -> Path:
    return Path(folder) / f"{name}.record.json"


def read_record(path: Path) -> dict | None:
    """The record at ``path``, or None when there is none or it cannot be read."""
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None


def stopping() -> bool:
    """Whether this process is being stopped: interrupted (SIGINT, SIGTERM in the command), its
    dask worker closing (its cluster was closed, its nanny restarts it), or Python exiting.

    A task that fails then failed because of it (a fit whose runtime is torn down under it, a
    connection closed), so its failure must not be recorded: an interrupted fleet run recorded
    the set in flight as failed ("ConnectionPool is closed"), and every rerun skipped it.
    """
    if _interrupts.pending() is not None or sys.is_finalizing():
        return True
    try:
        from distributed import get_worker
        from distributed.core import Status

        worker = get_worker()
    except (ImportError, ValueError):
        return False  # not in a dask worker
    return worker.status not in (Status.running, Status.paused)


def write_record(path: Path, record: dict) -> None:
    atomic_write_bytes(path, (json.dumps(to_jsonable(record), indent=1) + "\n").encode())


def unchanged(record: dict | None, input_hash: str, settings: dict) -> bool:
    """Whether a record was made from the same input and settings (and its outputs exist)."""
    if record is None or record.get("input_hash") != input_hash:
        return False
    if record.get("settings") != to_jsonable(settings):
        return False
    folder = Path(record.get("folder", "."))
    return all((folder / name).is_file() for name in record.get("outputs", []))


def write_parquet(table: pd.DataFrame, path: Path) -> Path:
    """Write a table to Parquet atomically (temporary file beside it, then rename)."""
    with atomic_output(path) as tmp:
        table.to_parquet(tmp, index=False)
    return Path(path)
