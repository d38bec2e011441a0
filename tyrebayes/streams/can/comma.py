"""comma.ai ``raw_can`` logs: the ``address``, ``data``, ``src`` and ``t`` arrays of a segment.

comma2k19 (and openpilot's processed logs) keep a segment's CAN bus in a folder
``processed_log/CAN/raw_can/`` of four NumPy arrays saved without the ``.npy`` extension:

- ``address``: the identifiers (int);
- ``data``: the payloads as fixed-width bytes (``|S8``). NumPy drops the trailing zero bytes of
  such strings, so the frame length (DLC) is not stored: :attr:`CanFrames.length` is the count
  of bytes up to the last non-zero one, a lower bound, and ``exact_length`` is False;
- ``src``: the bus as the panda numbers it (0-2 received; 128 and above the panda's own sent
  frames echoed back), named by its number;
- ``t``: seconds of the device's monotonic clock (not epoch time).

The same four arrays in one ``.npz`` archive (``numpy.savez_compressed``) are read alike: a
compact single-file form of the folder.

Examples
--------
>>> import numpy as np, tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "raw_can.npz"
>>> np.savez(path, address=[0x24, 0xAA], data=np.array([b"\\x01\\x02", b"\\x03"], "S8"),
...          src=[0, 0], t=[10.0, 10.01])
>>> frames, counts = read_comma_raw_can(path, ids={0x24})
>>> frames.data.tolist(), frames.length.tolist(), frames.exact_length, counts.frames
([[1, 2, 0, 0, 0, 0, 0, 0]], [2], False, 2)
"""

from __future__ import annotations

import zipfile
import zlib
from collections.abc import Collection
from pathlib import Path

import numpy as np

from ..._errors import BadInputError
from .frame_table import CanFrames, FrameCounts, empty_frames

#: The arrays of a comma ``raw_can`` folder, in the order they are named in messages.
ARRAYS: tuple[str, ...] = ("address", "data", "src", "t")


def _load_folder(path: Path) -> dict[str, np.ndarray]:
    arrays = {}
    for name in ARRAYS:
        candidates = [path / name, path / f"{name}.npy"]
        found = next((p for p in candidates if p.is_file()), None)
        if found is None:
            have = sorted(p.name for p in path.iterdir())[:8]
            raise BadInputError(
                f"CAN log {path.name}: expected a comma raw_can folder with arrays "
                f"{', '.join(ARRAYS)}, got no {name!r} (folder holds {have})"
            )
        try:
            arrays[name] = np.load(found, allow_pickle=False)
        except (OSError, ValueError, EOFError) as err:
            raise BadInputError(
                f"CAN log {path.name}: cannot read array {found.name!r} ({_first_line(err)})"
            ) from None
    return arrays


def _arrays_of(path: Path, archive) -> dict[str, np.ndarray]:
    missing = [name for name in ARRAYS if name not in archive.files]
    if missing:
        raise BadInputError(
            f"CAN log {path.name}: expected arrays {', '.join(ARRAYS)} in the archive, "
            f"got no {missing[0]!r} (archive holds {sorted(archive.files)[:8]})"
        )
    return {name: archive[name] for name in ARRAYS}


def _load_npz(path: Path) -> dict[str, np.ndarray]:
    try:
        # Opened here: np.load leaves its own handle open when the zip directory is corrupt.
        with open(path, "rb") as fh:
            loaded = np.load(fh, allow_pickle=False)
            if not isinstance(loaded, np.lib.npyio.NpzFile):
                raise BadInputError(
                    f"CAN log {path.name}: expected an archive of arrays {', '.join(ARRAYS)}, "
                    "got a single array"
                )
            with loaded as archive:
                return _arrays_of(path, archive)
    except BadInputError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as err:
        raise BadInputError(
            f"CAN log {path.name}: cannot read the .npz archive (truncated or corrupt file? "
            f"{_first_line(err)})"
        ) from None


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


def _checked(path: Path, arrays: dict[str, np.ndarray]) -> tuple[np.ndarray, ...]:
    """The four arrays as int64 ids, a uint8 payload table, int64 buses and float64 times."""
    shapes = {name: a.shape for name, a in arrays.items()}
    if any(len(s) != 1 for s in shapes.values()) or len({s[0] for s in shapes.values()}) != 1:
        raise BadInputError(
            f"CAN log {path.name}: expected four 1-d arrays of one length, got shapes {shapes}"
        )
    address, data, src, t = (arrays[name] for name in ARRAYS)
    if data.dtype.kind != "S":
        raise BadInputError(
            f"CAN log {path.name}: expected 'data' as fixed-width bytes (|S8), got {data.dtype}"
        )
    for name, a in (("address", address), ("src", src)):
        if a.dtype.kind not in "iu":
            raise BadInputError(f"CAN log {path.name}: expected integer {name!r}, got {a.dtype}")
    if t.dtype.kind != "f" or not np.all(np.isfinite(t)):
        raise BadInputError(
            f"CAN log {path.name}: expected finite float times 't', got {t.dtype}"
            + ("" if t.dtype.kind != "f" else f" with {int(np.sum(~np.isfinite(t)))} non-finite")
        )
    width = max(data.dtype.itemsize, 1)
    table = np.ascontiguousarray(data).view(np.uint8).reshape(-1, width)
    return address.astype(np.int64), table, src.astype(np.int64), t.astype(np.float64)


def read_comma_raw_can(
    path: str | Path, *, ids: Collection[int] | None = None, bus: str | None = None
) -> tuple[CanFrames, FrameCounts]:
    """Read a comma ``raw_can`` folder, or the same arrays in one ``.npz`` archive.

    Parameters
    ----------
    path : path-like
        A folder holding ``address``, ``data``, ``src`` and ``t`` (with or without ``.npy``), or
        a ``.npz`` archive of them.
    ids : collection of int, optional
        Identifiers to keep (default: all).
    bus : str, optional
        Bus to keep, the panda's ``src`` number as a string (``"0"``).

    Returns
    -------
    (CanFrames, FrameCounts)
        Frames in file order with ``exact_length`` False (the layout stores no DLC), and the
        counts (no error or remote frames exist in this layout).

    Raises
    ------
    BadInputError
        A missing array, an unreadable or corrupt array or archive, arrays of different lengths
        or unexpected types.
    """
    path = Path(path)
    arrays = _load_folder(path) if path.is_dir() else _load_npz(path)
    address, table, src, t = _checked(path, arrays)
    wanted = np.ones(address.size, dtype=bool) if ids is None else np.isin(address, list(ids))
    buses = tuple(str(b) for b in np.unique(src[wanted]))
    keep = wanted if bus is None else wanted & (src == int(bus) if bus.isdigit() else False)
    counts = FrameCounts(
        frames=int(address.size),
        error_frames=0,
        remote_frames=0,
        kept=int(np.count_nonzero(keep)),
        other_bus=int(np.count_nonzero(wanted & ~keep)),
        buses=buses,
    )
    if counts.kept == 0:
        return empty_frames(), counts
    rows = np.flatnonzero(keep)
    data = table[rows]
    nonzero = data != 0
    # Bytes up to the last non-zero one: the trailing zeros NumPy dropped are indistinguishable.
    length = np.where(nonzero.any(axis=1), data.shape[1] - np.argmax(nonzero[:, ::-1], axis=1), 0)
    names = tuple(str(b) for b in np.unique(src[rows]))
    index = np.searchsorted(np.array([int(n) for n in names]), src[rows])
    frames = CanFrames(
        time_s=t[rows],
        arbitration_id=address[rows],
        data=data.copy(),
        length=length.astype(np.int64),
        bus=index.astype(np.int64),
        bus_names=names,
        exact_length=False,
    )
    return frames, counts
