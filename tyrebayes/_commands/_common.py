"""Helpers shared by the CLI sub-commands: JSON output, atomic writes, input checks."""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .._errors import BadInputError


def _to_jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray) or hasattr(value, "__array__"):
        arr = np.asarray(value)
        return _to_jsonable(arr.item() if arr.ndim == 0 else arr.tolist())
    if isinstance(value, np.bool_ | bool):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        value = float(value)
        return value if math.isfinite(value) else None
    return value


def print_json(payload: dict) -> None:
    """Print a JSON object on stdout (NaN/inf become null, arrays become lists)."""
    json.dump(_to_jsonable(payload), sys.stdout, indent=2)
    sys.stdout.write("\n")


def existing_file(path: str) -> Path:
    """Return ``path`` as a Path, or raise BadInputError if it is not a readable file."""
    p = Path(path)
    if not p.is_file():
        raise BadInputError(f"file not found: expected a readable file, got '{path}'")
    return p


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path`` and rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_path(path: str | os.PathLike) -> tuple[Path, Path]:
    """Return (temporary path, final path) for writers that need a file name (netCDF, PNG).

    Write to the temporary path, then call ``os.replace(tmp, final)``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp{path.suffix}")
    return tmp, path


def add_can_arguments(parser) -> None:
    """``--profile``, ``--dbc``, ``--bus``: read the input as a raw CAN log with a car profile."""
    parser.add_argument(
        "--profile",
        default=None,
        help="car profile name (e.g. toyota_rav4_2017) or TOML path: the input is a raw CAN log "
        "(.log candump, .asc, .blf, .csv python-can, .mf4 bus logging) decoded with its DBC",
    )
    parser.add_argument(
        "--dbc", default=None, help="with --profile: a DBC instead of the profile's"
    )
    parser.add_argument(
        "--bus", default=None, help="with --profile: use frames of this bus only (e.g. can0, 0)"
    )


@contextlib.contextmanager
def stream_file(args, vehicle: str | None = None):
    """The stream file of a command: ``args.stream``, or a CAN log decoded into a temporary file.

    With ``--profile`` the log is decoded (:func:`tyrebayes.streams.can.read_can_log`, wheel
    speeds converted with ``vehicle``'s nominal radius) and written to a temporary Parquet file
    that lives for the ``with`` block, so that commands that read stream files take CAN logs
    unchanged.
    """
    if getattr(args, "profile", None) is None:
        for name in ("dbc", "bus"):
            if getattr(args, name, None) is not None:
                raise BadInputError(f"--{name}: expected together with --profile, got it alone")
        yield existing_file(args.stream)
        return
    from ..streams import write_stream
    from ..streams.can import read_can_log

    conversion = read_can_log(
        existing_file(args.stream), args.profile, dbc=args.dbc, vehicle=vehicle, bus=args.bus
    )
    with tempfile.TemporaryDirectory(prefix="tyrebayes-can-") as tmp:
        path = Path(tmp) / f"{Path(args.stream).stem}.parquet"
        write_stream(conversion.data, path)
        yield path
