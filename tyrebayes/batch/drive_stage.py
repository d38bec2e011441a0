"""The per-drive stage: read → validate → features → lateral fit → windows table and summary row.

:func:`process_drive` runs on a worker, one drive at a time. It writes, atomically and in this
order, ``drives/ID.windows.parquet`` (:mod:`.windows`), ``drives/ID.summary.parquet`` (one row,
:func:`~.drive_summary.drive_summary`) and ``drives/ID.record.json`` (:mod:`.records`); a drive
whose record matches its input's content hash and the settings is skipped. A bad log (corrupt,
unreadable, unknown vehicle, too few usable windows) gives a failed record with its one-line
reason, never an exception: one bad file must not stop a fleet run.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pandas as pd

from .._errors import BadInputError
from .._io import is_url, url_identity
from .drive_summary import drive_summary
from .lateral import DRIVE_LATERAL_COLUMNS, drive_lateral, lateral_off
from .manifest import DriveItem
from .records import (
    file_hash,
    read_record,
    record_path,
    stopping,
    unchanged,
    value_hash,
    write_parquet,
    write_record,
)
from .settings import RunSettings, configure_jax
from .windows import windows_table
from .worker_memory import WORKER, release_free_memory

DRIVES_DIR = "drives"
_REPAIRED = "time_faults_repaired"


def _content(path_or_name, resolve=Path) -> str:
    """A file's content hash; for a file that cannot be found or read, what was asked for.

    A missing log or an unknown vehicle is then part of the input too: its failure is recorded
    once and skipped on a rerun until the file appears. A log at a URL is not read for it: its
    store's key for the file's version stands for its content (:func:`tyrebayes._io.url_identity`:
    an object store's ETag, a local file's size and mtime), so that a remote log is fetched once.
    """
    try:
        if is_url(path_or_name):
            return url_identity(path_or_name)
        return file_hash(resolve(path_or_name))
    except (OSError, ValueError, ImportError, BadInputError):
        return f"unavailable: {path_or_name}"


def _profile_file(profile: str) -> Path:
    from .._resources import models_dir

    path = Path(profile)
    return path if path.suffix else models_dir() / "profiles" / f"{profile}.toml"


def drive_input_hash(item: DriveItem) -> str:
    """Content hash of everything a drive's outputs come from: the log, vehicle, profile, row."""
    from .._domain import vehicle_path

    parts = {
        "log": _content(item.path),
        "vehicle": _content(item.vehicle, vehicle_path),
        "profile": _content(item.profile, _profile_file) if item.profile else "",
        "row": {
            "tyre_set_id": item.tyre_set_id,
            "tyre_type": item.tyre_type,
            "surface": item.surface,
            "ambient_c": None if math.isnan(item.ambient_c) else item.ambient_c,
        },
    }
    return value_hash(parts)


def _read_log(item: DriveItem, vehicle) -> tuple[pd.DataFrame, str]:
    """The drive's table, and what was repaired in a CAN log's timestamps ("" if nothing)."""
    from ..streams import read_stream

    if not item.profile:
        return read_stream(item.path), ""
    from ..streams.can import read_can_log

    conversion = read_can_log(item.path, item.profile, vehicle=vehicle)
    return conversion.data, conversion.time_faults_text()


def _windows_and_summary(
    item: DriveItem, settings: RunSettings
) -> tuple[pd.DataFrame, dict, dict[str, float]]:
    """The drive's windows table and summary row, with the CPU seconds of each step."""
    from .._domain import load_vehicle
    from ..inference.tyre.data import observations_from_features
    from ..streams import compute_features, validate_stream
    from ..streams.tyre_temperature import features_tyre_temperature

    cpu = [time.process_time()]
    try:
        vehicle = load_vehicle(item.vehicle)
    except ValueError as err:
        raise BadInputError(str(err).splitlines()[0]) from None
    log, repaired = _read_log(item, vehicle)
    cpu.append(time.process_time())
    stream = validate_stream(log, vehicle)
    cpu.append(time.process_time())
    ambient = stream.mean_ambient_c() if math.isnan(item.ambient_c) else item.ambient_c
    features = compute_features(stream, vehicle)
    cpu.append(time.process_time())
    lateral = (
        drive_lateral(
            stream.data,
            vehicle,
            item.surface,
            method=settings.lateral_method,
            seed=settings.seed,
            source=item.path,
        )
        if settings.lateral
        else lateral_off()
    )
    cpu.append(time.process_time())
    temperature = features_tyre_temperature(features, ambient_c=ambient)
    windows = observations_from_features(
        features, temperature_c=temperature, window_s=settings.window_s
    )
    if len(windows) == 0:
        raise BadInputError("no usable windows (too short, too slow, or no traction)")
    table = windows_table(
        windows, drive_id=item.drive_id, tyre_set_id=item.tyre_set_id, surface=item.surface
    )
    row = drive_summary(item, stream, features, windows, vehicle)
    row.update(lateral)
    row["ambient_c"] = float(ambient)
    row[_REPAIRED] = repaired  # for the record, not the summary table (process_drive)
    cpu.append(time.process_time())
    steps = ("read", "validate", "features", "lateral", "windows_and_summary")
    return table, row, {k: b - a for k, a, b in zip(steps, cpu[:-1], cpu[1:], strict=True)}


def one_line(err: BaseException) -> str:
    """An exception as one line: bad input as its message, anything else with its type."""
    text = str(err).strip().splitlines()[0] if str(err).strip() else ""
    if isinstance(err, BadInputError):
        return text
    if isinstance(err, FileNotFoundError):
        return f"no such file '{err.filename}'"
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def process_drive(item: DriveItem, out_dir: str, settings: RunSettings) -> dict:
    """Run the per-drive stage for one drive (or skip it); returns its record.

    The record holds ``status`` (``"done"``, ``"failed"``), ``skipped`` (True when an earlier
    record with the same input hash and settings was reused), ``reason`` (one line, failed
    only), ``windows_hash`` (content hash of the windows table, what the tyre-set stage keys
    on), ``lateral`` (the drive's c_y or the reason it has none,
    :func:`~.lateral.drive_lateral`), ``seconds`` and ``cpu_seconds`` of this call
    (``step_cpu_seconds``: read, validate, features, lateral, windows and summary),
    ``peak_rss_mb`` of the worker process, the ``rss_mb_at_start`` and ``programs_dropped``
    (the worker dropped its compiled programs first to keep within
    ``settings.memory_budget_mb``: :mod:`.worker_memory`) and, for a raw CAN log,
    ``time_faults_repaired`` (the time faults repaired, :mod:`tyrebayes.streams.can`, as one
    line; "" when none; a log with more than 1 % of a message's frames at fault fails).
    """
    rss_at_start, dropped = WORKER.start("drive", settings.memory_budget_mb)
    start, cpu = time.perf_counter(), time.process_time()
    configure_jax(settings.jax_cache)
    folder = Path(out_dir) / DRIVES_DIR
    rec_path = record_path(folder, item.drive_id)
    config = settings.drive_settings()
    input_hash = drive_input_hash(item)
    old = read_record(rec_path)
    if unchanged(old, input_hash, config):
        return {**old, "skipped": True, "seconds": time.perf_counter() - start}
    record = {
        "item": "drive",
        "drive_id": item.drive_id,
        "tyre_set_id": item.tyre_set_id,
        "path": item.path,
        "input_hash": input_hash,
        "settings": config,
        "folder": str(folder),
    }
    try:
        table, row, step_cpu = _windows_and_summary(item, settings)
        repaired = row.pop(_REPAIRED)
        windows_path = write_parquet(table, folder / f"{item.drive_id}.windows.parquet")
        write_parquet(pd.DataFrame([row]), folder / f"{item.drive_id}.summary.parquet")
        record |= {
            "status": "done",
            "reason": "",
            "windows_hash": file_hash(windows_path),
            "surface": item.surface,
            "windows": int(len(table)),
            "duration_s": row["duration_s"],
            "step_cpu_seconds": step_cpu,
            # The drive's c_y (tyrebayes.batch.lateral), what its tyre set's estimate combines.
            "lateral": {k: row[k] for k in DRIVE_LATERAL_COLUMNS},
            # A CAN log's timestamps repaired (tyrebayes.streams.can.time_faults), or "".
            "time_faults_repaired": repaired,
            "outputs": [f"{item.drive_id}.windows.parquet", f"{item.drive_id}.summary.parquet"],
        }
    except Exception as err:  # noqa: BLE001 -- any bad log is recorded, never raised
        if stopping():
            raise  # the interruption's failure, not the item's: no record, redone next run
        record |= {"status": "failed", "reason": one_line(err), "outputs": []}
    record |= {
        "seconds": time.perf_counter() - start,
        "cpu_seconds": time.process_time() - cpu,
        "peak_rss_mb": WORKER.finish("drive", rss_at_start, dropped),
        "rss_mb_at_start": rss_at_start,
        "programs_dropped": dropped,
    }
    write_record(rec_path, record)
    release_free_memory()  # the worker idles, or starts its next task, without it
    return {**record, "skipped": False}
