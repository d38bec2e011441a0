"""Write a simulated drive as a car would (stream file) plus its truth beside it.

``write_drive(df, truth, "drive.parquet")`` writes

* ``drive.parquet`` — the stream (CSV, Parquet or MDF4 by suffix) via
  :func:`tyrebayes.streams.io.write_stream` (atomic);
* ``drive.truth.json`` — metadata, scalars and vectors of the truth (JSON, atomic);
* ``drive.truth.parquet`` — the per-sample truth (an hour at 100 Hz is ~10⁷ numbers, too many for
  JSON); the JSON names it under ``"samples_file"``.

Examples
--------
>>> import tempfile, pathlib
>>> from tyrebayes.simulate.drive import simulate_drive
>>> df, truth = simulate_drive(0, "compact_fwd", "summer", duration_s=10.0)
>>> path = pathlib.Path(tempfile.mkdtemp()) / "d.csv"
>>> files = write_drive(df, truth, path)
>>> back = read_drive_truth(path)
>>> back.c_xr == truth.c_xr and back.n_samples == len(df)
True
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pandas as pd

from .._io import atomic_write_bytes
from ..streams.io import write_stream
from .truth import DriveTruth


def truth_paths(stream_path: str | os.PathLike) -> tuple[Path, Path]:
    """The truth files that belong to a stream file: (``X.truth.json``, ``X.truth.parquet``)."""
    p = Path(stream_path)
    stem = p.name[: -len(p.suffix)] if p.suffix else p.name
    return p.with_name(f"{stem}.truth.json"), p.with_name(f"{stem}.truth.parquet")


def write_drive(df: pd.DataFrame, truth: DriveTruth, path: str | os.PathLike) -> dict[str, Path]:
    """Write the stream to ``path`` (format by suffix) and the truth beside it, all atomically.

    Returns
    -------
    dict
        ``{"stream": ..., "truth_json": ..., "truth_samples": ...}`` paths.
    """
    path = Path(path)
    if len(df) != truth.n_samples:
        raise ValueError(
            f"write_drive: expected the truth to have one row per stream row ({len(df)}), got "
            f"{truth.n_samples}"
        )
    json_path, samples_path = truth_paths(path)
    write_stream(df, path)
    tmp = samples_path.with_name(f".{samples_path.name}.{os.getpid()}.tmp")
    try:
        truth.samples().to_parquet(tmp, index=False)
        os.replace(tmp, samples_path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    meta = truth.scalars()
    meta["stream_file"] = path.name
    meta["samples_file"] = samples_path.name
    atomic_write_bytes(json_path, (json.dumps(meta, indent=2) + "\n").encode())
    return {"stream": path, "truth_json": json_path, "truth_samples": samples_path}


def read_drive_truth(stream_path: str | os.PathLike) -> DriveTruth:
    """Read the truth written by :func:`write_drive` for the stream at ``stream_path``."""
    json_path, _ = truth_paths(stream_path)
    if not json_path.is_file():
        raise ValueError(f"drive truth: expected {json_path}, got no such file")
    meta = json.loads(json_path.read_text())
    samples = pd.read_parquet(json_path.with_name(meta["samples_file"]))
    return DriveTruth.from_parts(meta, samples)
