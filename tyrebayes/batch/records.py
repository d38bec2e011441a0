"""Item records of a fleet run: content hashes, settings, atomic table writes, skip decisions.

Every item (a drive, a tyre set, the fleet) writes its outputs first and then its record,
``NAME.record.json`` beside them, atomically: ``{"status": "done" | "failed", "input_hash",
"settings", "reason", "outputs", "seconds", ...}``. A rerun skips an item whose record carries the
same input hash and settings (a failed one too: a corrupt file stays corrupt); an item killed
before its record was written has no record and runs again, its half-written temporary files
swept by the next writer (:mod:`tyrebayes._io`).
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import pandas as pd

from .._io import atomic_path, atomic_write_bytes, to_jsonable

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
    tmp, final = atomic_path(path)
    try:
        table.to_parquet(tmp, index=False)
        os.replace(tmp, final)
    finally:
        tmp.unlink(missing_ok=True)
    return final
