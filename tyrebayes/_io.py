"""File helpers shared by the library and the commands: atomic writes and JSON-ready values.

A writer never leaves a half-written file where a reader looks: it writes beside the target under
a recognisable temporary name (``.NAME.PID.tmp*``) and renames into place; the next writer of the
same target sweeps what a killed one left behind.
"""

from __future__ import annotations

import math
import os
import re
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np


def to_jsonable(value: Any) -> Any:
    """``value`` with arrays as lists, NumPy scalars as Python numbers, NaN/inf as None and a
    result object with ``as_dict`` (a fit's diagnostics) as its dict."""
    if hasattr(value, "as_dict"):
        return to_jsonable(value.as_dict())
    if isinstance(value, dict):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray) or hasattr(value, "__array__"):
        arr = np.asarray(value)
        return to_jsonable(arr.item() if arr.ndim == 0 else arr.tolist())
    if isinstance(value, np.bool_ | bool):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        value = float(value)
        return value if math.isfinite(value) else None
    return value


def _temporary_prefix(path: Path) -> str:
    """``.NAME.PID.tmp``: hidden, tied to its target and to the process that writes it."""
    return f".{path.name}.{os.getpid()}.tmp"


def sweep_stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Remove temporary files that a killed writer of ``path`` left beside it.

    A writer that survives its failure removes its own temporary file; one killed by SIGKILL
    (or a power cut) cannot. Its file, ``.NAME.PID.tmp*`` beside ``NAME``, is removed here when
    the process ``PID`` no longer runs, or when the file is older than a day (the PID was reused).
    A temporary file of a live writer is left alone. Assumes the folder is not written by writers
    on other hosts, whose PIDs this one cannot see.

    Parameters
    ----------
    path : path-like
        The target file.

    Returns
    -------
    list of Path
        The files removed.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / ".fit.nc.999999999.tmp.nc").write_bytes(b"half a file")
    >>> [p.name for p in sweep_stale_temporaries(folder / "fit.nc")]
    ['.fit.nc.999999999.tmp.nc']
    """
    path = Path(path)
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.(\d+)\.tmp")
    removed = []
    try:
        candidates = list(path.parent.iterdir())
    except OSError:
        return removed  # no folder yet: nothing to sweep
    for candidate in candidates:
        match = pattern.match(candidate.name)
        if match is None or not candidate.is_file():
            continue
        pid = int(match.group(1))
        try:
            old = time.time() - candidate.stat().st_mtime > _STALE_AFTER_S
        except OSError:
            continue  # removed meanwhile
        if pid != os.getpid() and (old or not _process_alive(pid)):
            candidate.unlink(missing_ok=True)
            removed.append(candidate)
    return removed


#: A temporary file untouched this long is stale whatever its PID says (PIDs are reused).
_STALE_AFTER_S = 24 * 3600.0


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # another user's process: alive; an absurd PID: leave it to the age rule
    return True


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path`` and rename it into place.

    The temporary file is ``.NAME.PID.tmpXXXXXXXX``; stale ones of earlier, killed writers of the
    same target are swept first (:func:`sweep_stale_temporaries`).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    sweep_stale_temporaries(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=_temporary_prefix(path))
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_path(path: str | os.PathLike) -> tuple[Path, Path]:
    """Return (temporary path, final path) for writers that need a file name (netCDF, PNG).

    Write to the temporary path ``.NAME.PID.tmp.SUFFIX`` (the suffix keeps format detection by
    name working), then call ``os.replace(tmp, final)``; remove the temporary path if writing
    fails. Stale temporary files of earlier, killed writers of the same target are swept first.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    sweep_stale_temporaries(path)
    tmp = path.with_name(f"{_temporary_prefix(path)}{path.suffix}")
    return tmp, path
