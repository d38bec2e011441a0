"""Raw CAN frames from a bus log: the frame table, the counts, and the readers by file type.

candump logs (``.log``) are parsed with NumPy (:mod:`.candump`), because python-can's line reader
spends ~5 µs per frame in Python and a full bus logs ~9 million frames an hour. comma.ai
``raw_can`` folders (and ``.npz`` archives of their arrays) are read with NumPy (:mod:`.comma`).
Vector ASC, BLF, python-can CSV, MF4 bus logging (through asammdf) and PEAK TRC are read with
python-can's readers.
Only the frames of the wanted identifiers are kept; error and remote frames are counted and
skipped; timestamps are kept as logged [s].

Examples
--------
>>> import can, tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "bus.asc"
>>> with can.Logger(str(path)) as log:
...     log.on_message_received(can.Message(timestamp=1.0, arbitration_id=0x24, data=b"\\x01" * 8))
>>> frames, counts = read_frames(path, ids={0x24})
>>> counts.frames, frames.data.shape
(1, (1, 8))
"""

from __future__ import annotations

import gc
import os
import re
import struct
import sys
from collections.abc import Collection
from pathlib import Path

import numpy as np

from ..._errors import BadInputError
from .frame_table import CanFrames as CanFrames
from .frame_table import FrameCounts as FrameCounts
from .frame_table import empty_frames as empty_frames

#: Suffixes read as CAN bus logs (candump, Vector ASC/BLF, python-can CSV, MF4 bus logging, TRC,
#: comma raw_can arrays in one archive). A folder is read as a comma raw_can folder.
CAN_SUFFIXES: tuple[str, ...] = (".log", ".asc", ".blf", ".csv", ".mf4", ".trc", ".npz")


def stack_payloads(payloads: list[bytes]) -> tuple[np.ndarray, np.ndarray]:
    """Payloads as a zero-padded uint8 table and their lengths."""
    lengths = np.fromiter((len(p) for p in payloads), dtype=np.int64, count=len(payloads))
    width = int(lengths.max()) if lengths.size else 8
    if lengths.size and np.all(lengths == width):
        table = np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(-1, width)
    else:
        table = np.frombuffer(
            b"".join(p.ljust(width, b"\0") for p in payloads), dtype=np.uint8
        ).reshape(-1, width)
    return table.copy(), lengths


# Lines an ASC file may hold besides frames: a timestamp first, or a header/trigger keyword.
_ASC_LINE = re.compile(
    r"\s*(?:\d+\.\d+(?:\s|$)|date\b|base\b|internal events|no internal events|"
    r"begin triggerblock|end triggerblock|//)",
    re.IGNORECASE,
)
# BLF file header: "LOGG", header size, ..., file size at field 10 (python-can's layout).
_BLF_HEADER = struct.Struct("<4sLBBBBBBBBQQLL8H8H")


def _check_asc(path: Path) -> None:
    """Garbage lines and a missing end: python-can's ASC reader skips both silently."""
    last = ""
    with open(path, encoding="utf-8", errors="replace") as fh:
        for number, line in enumerate(fh, start=1):
            text = line.strip()
            if not text:
                continue
            last = text
            if not _ASC_LINE.match(text):
                raise BadInputError(
                    f"CAN log {path.name}: line {number}: expected an ASC frame or header line, "
                    f"got {text[:60]!r}"
                )
    if not last.lower().startswith("end triggerblock"):
        raise BadInputError(
            f"CAN log {path.name}: expected 'End TriggerBlock' as the last line, got "
            f"{last[:60]!r} (truncated file?)"
        )


def _check_blf(path: Path) -> None:
    """A file shorter than its header says: python-can's BLF reader stops there silently."""
    with open(path, "rb") as fh:
        head = fh.read(_BLF_HEADER.size)
    if len(head) < _BLF_HEADER.size or head[:4] != b"LOGG":
        raise BadInputError(f"CAN log {path.name}: expected a BLF file header 'LOGG', got none")
    declared = _BLF_HEADER.unpack(head)[10]
    actual = path.stat().st_size
    if declared and actual < declared:
        raise BadInputError(
            f"CAN log {path.name}: expected {declared} bytes (BLF header), got {actual} "
            "(truncated file)"
        )


def _read_python_can(
    path: Path, ids: Collection[int] | None, bus: str | None
) -> tuple[CanFrames, FrameCounts]:

    times: list[float] = []
    arb: list[int] = []
    payloads: list[bytes] = []
    frame_bus: list[str] = []
    n_data = n_error = n_remote = n_other = 0
    buses: set[str] = set()
    wanted = None if ids is None else frozenset(ids)
    if path.suffix.lower() == ".asc":
        _check_asc(path)
    elif path.suffix.lower() == ".blf":
        _check_blf(path)
    reader = _open_reader(path)
    try:
        with reader:
            for msg in reader:
                if msg.is_error_frame:
                    n_error += 1
                    continue
                if msg.is_remote_frame:
                    n_remote += 1
                    continue
                n_data += 1
                if wanted is not None and msg.arbitration_id not in wanted:
                    continue
                channel = "" if msg.channel is None else str(msg.channel)
                buses.add(channel)
                if bus is not None and channel != bus:
                    n_other += 1
                    continue
                times.append(msg.timestamp)
                arb.append(msg.arbitration_id)
                payloads.append(bytes(msg.data))
                frame_bus.append(channel)
    except BadInputError:
        raise
    except Exception as err:
        # python-can raises struct/zlib/value errors on truncated or corrupt files.
        raise BadInputError(
            f"CAN log {path.name}: cannot read past frame {n_data + n_error + n_remote} "
            f"(truncated or corrupt file? {_first_line(err)})"
        ) from None
    names = tuple(sorted(buses))
    counts = FrameCounts(n_data, n_error, n_remote, len(times), n_other, names)
    if not times:
        return empty_frames(), counts
    data, lengths = stack_payloads(payloads)
    index = {name: i for i, name in enumerate(names)}
    frames = CanFrames(
        np.asarray(times, dtype=np.float64),
        np.asarray(arb, dtype=np.int64),
        data,
        lengths,
        np.fromiter((index[b] for b in frame_bus), dtype=np.int64, count=len(frame_bus)),
        names,
    )
    return frames, counts


def _open_reader(path: Path):
    """python-can's reader for the suffix, or BadInputError with the reason."""
    import can

    # asammdf's MDF4.__del__ raises on a half-opened (truncated) file; that would print a
    # traceback under the one-line error, so it is silenced while the failed reader is freed.
    hook = sys.unraisablehook
    sys.unraisablehook = lambda unraisable: None
    try:
        try:
            return can.LogReader(str(path))
        except Exception as err:
            reason = _first_line(err)
            del err
        gc.collect()
    finally:
        sys.unraisablehook = hook
    raise BadInputError(f"CAN log {path.name}: cannot open ({reason})")


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


def read_frames(
    path: str | os.PathLike,
    *,
    ids: Collection[int] | None = None,
    bus: str | None = None,
) -> tuple[CanFrames, FrameCounts]:
    """Read the data frames of a CAN log.

    Parameters
    ----------
    path : path-like
        ``.log`` (candump -L), ``.asc``, ``.blf``, ``.csv`` (python-can CSV), ``.mf4`` (ASAM MDF
        bus logging), ``.trc``, or a comma ``raw_can`` folder (``address``, ``data``, ``src``,
        ``t`` arrays) or ``.npz`` archive of those arrays.
    ids : collection of int, optional
        Identifiers to keep (default: all).
    bus : str, optional
        Keep frames of this bus only (``can0``; ``0`` for the first channel of an ASC/BLF log).

    Returns
    -------
    (CanFrames, FrameCounts)

    Raises
    ------
    BadInputError
        Missing file, unknown suffix, garbage lines, a truncated or corrupt file.
    """
    path = Path(path)
    if path.is_dir():
        from .comma import read_comma_raw_can

        return read_comma_raw_can(path, ids=ids, bus=bus)
    suffix = path.suffix.lower()
    if suffix not in CAN_SUFFIXES:
        raise BadInputError(
            f"CAN log {path.name}: expected a suffix in {list(CAN_SUFFIXES)}, got '{path.suffix}'"
        )
    if not path.is_file():
        raise BadInputError(f"CAN log: expected a readable file, got '{path}'")
    if suffix == ".log":
        from .candump import read_candump

        return read_candump(path, ids=ids, bus=bus)
    if suffix == ".npz":
        from .comma import read_comma_raw_can

        return read_comma_raw_can(path, ids=ids, bus=bus)
    return _read_python_can(path, ids, bus)
