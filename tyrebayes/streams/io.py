"""Read and write stream files: CSV, Parquet and MDF4 (ASAM MDF, via asammdf).

CSV and Parquet hold one row per sample in the contract of :mod:`tyrebayes.streams.schema`. MDF4
files from automotive loggers keep every channel on its own time base and under the logger's
channel names; :func:`read_stream` maps the names (``channel_map``) and merges the time bases into
one table (NaN where a channel has no sample), which :func:`tyrebayes.streams.validate_stream` then
resamples onto one time base.

Examples
--------
>>> import pandas as pd, tempfile, pathlib
>>> df = pd.DataFrame({"time": [0.0, 0.01], "ax": [0.1, 0.2]})
>>> path = pathlib.Path(tempfile.mkdtemp()) / "s.parquet"
>>> write_stream(df, path)
>>> read_stream(path)["ax"].tolist()
[0.1, 0.2]
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from .._errors import BadInputError
from .._io import atomic_output, is_url, url_name
from .schema import CHANNELS, OPTIONAL_COLUMNS, REQUIRED_COLUMNS
from .time_bases import merge_time_bases

_CSV = (".csv",)
_PARQUET = (".parquet", ".pq")
_MDF = (".mf4", ".mdf")
SUPPORTED_SUFFIXES: tuple[str, ...] = _CSV + _PARQUET + _MDF


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_SUFFIXES:
        raise BadInputError(
            f"stream file {path.name}: expected a suffix in {list(SUPPORTED_SUFFIXES)}, "
            f"got '{path.suffix}'"
        )
    return suffix


# First bytes of the binary formats a stream file may really be, whatever its name says.
_MAGIC = {
    b"PAR1": "a Parquet file (rename it to .parquet)",
    b"MDF ": "an MDF4 file (rename it to .mf4)",
    b"PK\x03\x04": "a zip archive (unpack it)",
}


def _printable(text: str, limit: int = 80) -> str:
    """One line of ``text`` fit for a terminal: control and undecodable bytes as '?', truncated."""
    line = "".join(c if c.isprintable() and c != "\ufffd" else "?" for c in text)
    return line if len(line) <= limit else line[: limit - 3] + "..."


def _sniff_csv(head: bytes, name: str) -> None:
    """A file named .csv that holds a binary format: say which, instead of parsing junk."""
    for magic, what in _MAGIC.items():
        if head.startswith(magic):
            raise BadInputError(f"stream file {name}: expected CSV text, got {what}")
    if b"\x00" in head:
        raise BadInputError(f"stream file {name}: expected CSV text, got binary data")


def _read_table(path: Path | str, suffix: str, name: str, head: bytes = b"") -> pd.DataFrame:
    """A CSV or Parquet file, local or at an fsspec URL (pandas and pyarrow open those: pyarrow's
    own file systems where it has one, fsspec's otherwise)."""
    if suffix in _CSV:
        if not head:
            with Path(path).open("rb") as fh:
                head = fh.read(4096)
        _sniff_csv(head, name)
    try:
        if suffix in _CSV:
            # The pyarrow engine parses in parallel and is ~5x faster than the C engine.
            return pd.read_csv(path, engine="pyarrow")
        return pd.read_parquet(path)
    except Exception as err:  # pandas' and pyarrow's own (ParserError, ArrowInvalid, OSError)
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise BadInputError(f"stream file {name}: cannot parse ({_printable(first)})") from None


def _read_url(url: str, channel_map: Mapping[str, str] | None) -> pd.DataFrame:
    """A stream file at an fsspec URL (``file://``, ``s3://``, ``gs://``, ``memory://`` ...).

    CSV and Parquet are read where they are; an MDF4 file is read into memory first (asammdf
    reads a file object). Whether the file exists is asked first, so that a missing one is
    "expected a readable file" as a local one is.
    """
    import fsspec

    name = url_name(url)
    suffix = _suffix(Path(name))
    try:
        with fsspec.open(url, "rb") as fh:
            head = fh.read(4096) if suffix in _CSV else b""
            data = fh.read() if suffix in _MDF else b""
    except FileNotFoundError:
        raise BadInputError(f"stream file: expected a readable file, got '{url}'") from None
    except (OSError, ValueError, ImportError) as err:  # no such protocol, or not installed
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise BadInputError(
            f"stream file: expected a readable file, got '{url}' ({_printable(first)})"
        ) from None
    if suffix in _MDF:
        import io

        return _read_mdf(io.BytesIO(head + data), channel_map, name)
    df = _read_table(url, suffix, name, head=head or b" ")
    if channel_map:
        df = df.rename(columns=dict(channel_map))
    return df


def _read_mdf(path, channel_map: Mapping[str, str] | None, name: str = "") -> pd.DataFrame:
    from asammdf import MDF  # slow import, only when an MDF file is read

    name = name or Path(path).name
    try:
        mdf = MDF(path)
    except Exception as err:
        raise BadInputError(f"stream file {name}: not a readable MDF file ({err})") from None
    try:
        masters = {
            group.channels[group.channel_group.master_index].name
            for group in mdf.groups
            if getattr(group.channel_group, "master_index", None) is not None
        }
    except Exception:
        masters = set()
    masters.add("time")
    wanted = set(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)
    columns: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    try:
        for source in mdf.channels_db:
            target = channel_map.get(source, source) if channel_map else source
            if source in masters and target == source:
                continue
            if target not in wanted or target == "time":
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                signal = mdf.get(source, raw=False)
            samples = np.asarray(signal.samples, dtype=float)
            columns[target] = (np.asarray(signal.timestamps, dtype=float), samples)
    finally:
        mdf.close()
    if not columns:
        raise BadInputError(
            f"stream file {name}: expected MDF channels named like "
            f"{list(REQUIRED_COLUMNS[1:])} "
            "(or a channel_map to them), got none"
        )
    return merge_time_bases(columns)


def read_stream(
    path: str | os.PathLike,
    channel_map: Mapping[str, str] | None = None,
    *,
    profile=None,
    dbc: str | os.PathLike | None = None,
    vehicle=None,
) -> pd.DataFrame:
    """Read a stream file into a DataFrame with contract column names (not yet validated).

    Parameters
    ----------
    path : path-like or str
        ``.csv``, ``.parquet``/``.pq`` or ``.mf4``/``.mdf``, a local path or an fsspec URL
        (``file:///abs/drive.parquet``, ``s3://bucket/drive.parquet`` with ``s3fs`` installed);
        with ``profile``, a local raw CAN log (candump ``.log``, ``.asc``, ``.blf``, python-can
        ``.csv``, MF4 bus logging ``.mf4``).
    channel_map : mapping, optional
        Source channel/column name -> contract name, e.g. ``{"WhlSpd_FL": "wheel_speed_fl"}``.
        Names not in the map are used as they are.
    profile : CarProfile, str or path-like, optional
        Car profile (name in ``models/profiles/`` or TOML path): read ``path`` as a CAN log and
        decode it with the profile's DBC (:func:`tyrebayes.streams.can.read_can_log`).
    dbc : path-like, optional
        With ``profile``: a DBC to use instead of the profile's.
    vehicle : Vehicle, str or path-like, optional
        With ``profile``: the vehicle whose nominal wheel radius converts wheel speeds (default:
        the profile's).

    Returns
    -------
    pandas.DataFrame
        One row per time instant; for MDF the union of all channels' instants, with NaN where a
        channel was not sampled. Pass it to :func:`tyrebayes.streams.validate_stream`.

    Raises
    ------
    BadInputError
        Missing file, unknown suffix, or a file that cannot be parsed; a URL whose protocol
        fsspec does not know or whose implementation is not installed.

    Examples
    --------
    >>> from tyrebayes._resources import data_dir
    >>> df = read_stream(data_dir() / "comma2k19_rav4_segment.csv")
    >>> df.shape, list(df.columns[:2])
    ((4974, 11), ['time', 'wheel_speed_fl'])
    """
    if profile is not None:
        from .can import read_can_log

        if channel_map:
            raise BadInputError("read_stream: expected a channel_map or a profile, got both")
        return read_can_log(path, profile, dbc=dbc, vehicle=vehicle).data
    if is_url(path):
        return _read_url(path, channel_map)
    path = Path(path)
    suffix = _suffix(path)
    if not path.is_file():
        raise BadInputError(f"stream file: expected a readable file, got '{path}'")
    if suffix in _MDF:
        return _read_mdf(path, channel_map)
    df = _read_table(path, suffix, path.name)
    if channel_map:
        df = df.rename(columns=dict(channel_map))
    return df


def _write_mdf(df: pd.DataFrame, path: Path) -> None:
    from asammdf import MDF, Signal

    if "time" not in df.columns:
        raise BadInputError("write_stream: expected a 'time' column for MDF4, got none")
    time = df["time"].to_numpy(dtype=float)
    mdf = MDF(version="4.10")
    for name in df.columns:
        if name == "time":
            continue
        values = df[name].to_numpy()
        if not np.issubdtype(values.dtype, np.number):
            continue  # MDF holds numeric channels only; text columns are dropped
        values = values.astype(float)
        keep = np.isfinite(values)  # a dropped sample is simply absent from an MDF channel
        unit = CHANNELS[name].unit if name in CHANNELS else ""
        signal = Signal(values[keep], timestamps=time[keep], name=name, unit=unit)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mdf.append([signal], comment=name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mdf.save(path, overwrite=True)
    mdf.close()


def write_stream(df: pd.DataFrame, path: str | os.PathLike) -> None:
    """Write a stream atomically; the format follows the suffix (CSV, Parquet or MDF4).

    The file appears complete or not at all: it is written under a temporary name beside ``path``
    and renamed into place. In MDF4 each channel is one group with its own time base and NaN
    (dropped) samples are left out.

    Parameters
    ----------
    df : pandas.DataFrame
        Columns in the stream contract (``time`` first by convention); extra columns are
        written too.
    path : path-like
        Target file; its suffix selects the format.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> df = pd.DataFrame({"time": [0.0, 0.01], "ax": [0.1, 0.2]})
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     write_stream(df, Path(folder) / "drive.parquet")
    ...     read_stream(Path(folder) / "drive.parquet").equals(df)
    True
    """
    suffix = _suffix(Path(path))
    # Sweeps what a killed writer of this file left behind; an interruption while writing
    # leaves the previous file.
    with atomic_output(path) as tmp:
        if suffix in _CSV:
            df.to_csv(tmp, index=False, float_format="%.12g")
        elif suffix in _PARQUET:
            df.to_parquet(tmp, index=False)
        else:
            _write_mdf(df, tmp)
