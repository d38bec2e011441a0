"""File helpers shared by the library and the commands: atomic writes and JSON-ready values.

A writer never leaves a half-written file where a reader looks: it writes beside the target under
a recognisable temporary name (``.NAME.PID.tmp*``) and renames into place; the next writer of the
same target sweeps what a killed one left behind. A signal (SIGINT, SIGTERM in the command line:
:mod:`tyrebayes._interrupts`) that arrives while a file is written is held until it is written,
and then drops the temporary file instead of replacing the previous one. Files are created with
the permissions the umask gives (0644 under the usual 022), as ``open`` would.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from . import _interrupts


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
    return _sweep(path.parent, re.compile(rf"^\.{re.escape(path.name)}\.(\d+)\.tmp"))


def sweep_folder_temporaries(folder: str | os.PathLike) -> list[Path]:
    """Remove every stale temporary file (``.NAME.PID.tmp*``) in ``folder``, whatever its target.

    For a folder whose writers are known to be gone (a fleet run's, after its local cluster
    closed); the rules are :func:`sweep_stale_temporaries`' (a live writer's file stays).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / ".a.json.999999999.tmpab12").write_bytes(b"{")
    >>> [p.name for p in sweep_folder_temporaries(folder)]
    ['.a.json.999999999.tmpab12']
    """
    return _sweep(Path(folder), re.compile(r"^\..+\.(\d+)\.tmp"))


def _sweep(folder: Path, pattern: re.Pattern) -> list[Path]:
    removed: list[Path] = []
    try:
        candidates = list(folder.iterdir())
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


def _umask() -> int:
    """The process's umask, read without changing it where Linux says it (threads may write)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _as_if_opened(fd: int) -> None:
    """Give a ``mkstemp`` file (0600) the mode ``open`` would have given it: 0666 less the
    umask. A result file is for the user's tools and colleagues as much as for this process."""
    os.fchmod(fd, 0o666 & ~_umask())


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path`` and rename it into place.

    The temporary file is ``.NAME.PID.tmpXXXXXXXX``; stale ones of earlier, killed writers of the
    same target are swept first (:func:`sweep_stale_temporaries`). The file gets the mode the
    umask gives. An interruption while writing leaves the previous file as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    sweep_stale_temporaries(path)
    _interrupts.check()
    with _interrupts.deferred():
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=_temporary_prefix(path))
        try:
            with os.fdopen(fd, "wb") as fh:
                _as_if_opened(fh.fileno())
                fh.write(data)
            if _interrupts.pending() is None:
                os.replace(tmp, path)
        finally:
            Path(tmp).unlink(missing_ok=True)


def atomic_path(path: str | os.PathLike) -> tuple[Path, Path]:
    """Return (temporary path, final path) for writers that need a file name (netCDF, PNG).

    Write to the temporary path ``.NAME.PID.tmp.SUFFIX`` (the suffix keeps format detection by
    name working), then call ``os.replace(tmp, final)``; remove the temporary path if writing
    fails. Stale temporary files of earlier, killed writers of the same target are swept first.
    After an interruption (one that code on the way swallowed) it raises it again instead:
    nothing new is written then. :func:`atomic_output` does all of this, and holds signals
    while the file is written.
    """
    path = Path(path)
    _interrupts.check()
    path.parent.mkdir(parents=True, exist_ok=True)
    sweep_stale_temporaries(path)
    tmp = path.with_name(f"{_temporary_prefix(path)}{path.suffix}")
    return tmp, path


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path to write ``path`` under; renamed into place when the block succeeds.

    SIGINT and SIGTERM are held while the block runs (a netCDF or Parquet library is not
    stopped half-way through a file, where it can hang or crash); if one came, the temporary
    file is removed, the previous ``path`` is left as it was, and the signal is raised then
    (:class:`tyrebayes._interrupts.Interrupted`). An exception in the block removes the
    temporary file too.

    Examples
    --------
    >>> import tempfile
    >>> target = Path(tempfile.mkdtemp()) / "out.txt"
    >>> with atomic_output(target) as tmp:
    ...     _ = tmp.write_text("complete")
    >>> target.read_text(), [p.name for p in target.parent.iterdir()]
    ('complete', ['out.txt'])
    """
    tmp, final = atomic_path(path)
    try:
        with _interrupts.deferred():
            yield tmp
            if _interrupts.pending() is None:
                os.replace(tmp, final)
    finally:
        tmp.unlink(missing_ok=True)


# A scheme of two letters or more: "C://x" stays a Windows path.
_URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]+://")


def is_url(path: str | os.PathLike) -> bool:
    """Whether ``path`` is an fsspec URL (``file:///abs/x.parquet``, ``s3://bucket/x.parquet``,
    ``memory://x``) rather than a local path.

    Examples
    --------
    >>> is_url("s3://bucket/drive.parquet"), is_url("logs/drive.parquet"), is_url("C://x")
    (True, False, False)
    """
    return isinstance(path, str) and _URL.match(path) is not None


def url_name(url: str) -> str:
    """The file name at the end of a URL's path (no query, no fragment).

    Examples
    --------
    >>> url_name("s3://bucket/logs/drive.parquet?versionId=3")
    'drive.parquet'
    """
    from urllib.parse import urlsplit

    return urlsplit(url).path.rstrip("/").rsplit("/", 1)[-1]


def url_identity(url: str) -> str:
    """What names the version of the file at ``url`` without reading it: fsspec's ``ukey`` (a
    hash of the store's listing: S3's and GCS's ETag, a local file's size and mtime).

    Raises
    ------
    FileNotFoundError
        No file there.
    ValueError
        A protocol fsspec does not know.
    ImportError
        A protocol whose fsspec implementation (``s3fs``, ``gcsfs``, ...) is not installed.
    """
    from fsspec.core import url_to_fs

    fs, path = url_to_fs(url)
    if not fs.isfile(path):
        raise FileNotFoundError(2, "No such file", url)
    return f"{fs.protocol if isinstance(fs.protocol, str) else fs.protocol[0]}:{fs.ukey(path)}"
