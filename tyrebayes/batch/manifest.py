"""The fleet-run manifest: which drive logs to process, of which vehicle and tyre set.

A manifest is a table (CSV or Parquet) with one row per drive log:

* ``path`` — the log (stream CSV/Parquet/MDF4, or a raw CAN log with ``profile``); relative paths
  are taken from the manifest's folder; a stream file may be an fsspec URL
  (``file:///abs/drive.parquet``, ``s3://bucket/drive.parquet`` with ``s3fs`` on the workers),
  read where it is (:func:`tyrebayes.streams.read_stream`);
* ``vehicle`` — preset name or vehicle TOML path;
* ``tyre_set_id`` — the tyre set the drive was made on (drives of one set are fitted jointly);
* optional ``tyre_type`` (``winter``, ``all_season``, ``summer``), ``surface`` (default ``dry``),
  ``ambient_c`` (default: the log's ``ambient_temperature``, else 20 °C), ``profile`` (a car
  profile for raw CAN logs, :mod:`tyrebayes.streams.can`).

Or a glob pattern (``"logs/*.parquet"``) with one vehicle: every match is a drive of one tyre set
named after the vehicle.

Rows are checked for their form here (columns, types, known surfaces and tyre types) and
against each other before any work starts: a log listed twice (under any name, through links) and
a tyre set given two tyre types are refused with their row numbers. Whether a file exists, can
be read or names a known vehicle is the per-drive stage's question, so that one bad row is
recorded as a failed drive and never stops a fleet run.

Examples
--------
>>> import pandas as pd, tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> pd.DataFrame({"path": ["a.parquet"], "vehicle": ["compact_fwd"], "tyre_set_id": ["s1"]}).to_csv(
...     folder / "m.csv", index=False)
>>> [d.tyre_set_id for d in read_manifest(folder / "m.csv")]
['s1']
"""

from __future__ import annotations

import dataclasses
import glob as globlib
import hashlib
import math
import os
import re
from pathlib import Path

import pandas as pd

from .._domain import SURFACES, TYRE_TYPES
from .._errors import BadInputError
from .._io import is_url, url_name

REQUIRED = ("path", "vehicle", "tyre_set_id")
OPTIONAL = ("tyre_type", "surface", "ambient_c", "profile")
DEFAULT_SURFACE = "dry"


@dataclasses.dataclass(frozen=True)
class DriveItem:
    """One drive log of a fleet run (a manifest row, resolved).

    Attributes
    ----------
    drive_id : str
        Stable name of the drive's outputs: the file stem and a hash of its resolved path.
    path : str
        Absolute path of the log, or its URL.
    vehicle : str
        Preset name or vehicle TOML path (absolute).
    tyre_set_id : str
        The tyre set.
    tyre_type : str
        ``winter``, ``all_season``, ``summer`` or ``""`` (not given).
    surface : str
        One of :data:`tyrebayes.SURFACES`.
    ambient_c : float
        Ambient temperature [°C]; NaN: from the log (else 20 °C).
    profile : str
        Car profile for a raw CAN log, ``""`` for a stream file.
    """

    drive_id: str
    path: str
    vehicle: str
    tyre_set_id: str
    tyre_type: str
    surface: str
    ambient_c: float
    profile: str


def _drive_id(path: str) -> str:
    name = url_name(path) if is_url(path) else Path(path).name
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", name)[:60]
    return f"{stem}-{hashlib.sha256(path.encode()).hexdigest()[:10]}"


def _text(value) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return str(value).strip()


def _resolve(value: str, base: Path, *, is_path: bool) -> str:
    """Relative file paths against the manifest's folder; preset names and URLs stay as they
    are."""
    if not value or is_url(value):
        return value
    p = Path(value).expanduser()
    if not is_path and not p.suffix:
        return value  # a preset name
    return str(p if p.is_absolute() else (base / p).resolve())


def _same_file_key(path: str) -> str:
    """One key per file: a local file through links, and under a ``file://`` URL too (one log
    under two names is still one drive); other URLs as written."""
    if is_url(path):
        if not path.lower().startswith("file://"):
            return path
        from urllib.parse import unquote, urlsplit

        path = unquote(urlsplit(path).path)
    return os.path.realpath(path)


def _read_table(path: Path) -> pd.DataFrame:
    if not path.is_file():
        raise BadInputError(f"manifest: expected a CSV or Parquet file, got no file '{path}'")
    try:
        if path.suffix.lower() in (".parquet", ".pq"):
            return pd.read_parquet(path)
        return pd.read_csv(path, dtype=str, keep_default_na=False, na_values=[""])
    except (ValueError, OSError, pd.errors.ParserError) as err:
        reason = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise BadInputError(f"manifest {path}: expected CSV or Parquet, got {reason}") from None


def manifest_from_table(table: pd.DataFrame, base: str | os.PathLike = ".") -> list[DriveItem]:
    """Check a manifest table and resolve it into :class:`DriveItem` s (one per row, in order).

    Raises
    ------
    BadInputError
        One line naming the row: a missing column, an empty ``path``/``vehicle``/
        ``tyre_set_id``, an unknown ``tyre_type`` or ``surface``, a non-numeric ``ambient_c``,
        a log listed twice (both rows, and the two tyre sets where they differ), a tyre set
        given two tyre types (both rows).
    """
    missing = [c for c in REQUIRED if c not in table.columns]
    if missing:
        raise BadInputError(
            f"manifest: expected columns {list(REQUIRED)} (optional {list(OPTIONAL)}), "
            f"missing {missing}"
        )
    if len(table) == 0:
        raise BadInputError("manifest: expected at least one drive, got an empty table")
    base = Path(base)
    items, seen = [], {}
    for i, row in enumerate(table.to_dict("records")):
        line = f"manifest row {i + 1}"
        values = {c: _text(row.get(c)) for c in (*REQUIRED, "tyre_type", "surface", "profile")}
        for c in REQUIRED:
            if not values[c]:
                raise BadInputError(f"{line}: expected a value in '{c}', got none")
        if values["tyre_type"] and values["tyre_type"] not in TYRE_TYPES:
            raise BadInputError(
                f"{line}: tyre_type expected one of {list(TYRE_TYPES)}, got {values['tyre_type']!r}"
            )
        surface = values["surface"] or DEFAULT_SURFACE
        if surface not in SURFACES:
            raise BadInputError(
                f"{line}: surface expected one of {list(SURFACES)}, got {surface!r}"
            )
        ambient_text = _text(row.get("ambient_c"))
        try:
            ambient = float(ambient_text) if ambient_text else math.nan
        except ValueError:
            raise BadInputError(
                f"{line}: ambient_c expected a temperature in °C, got {ambient_text!r}"
            ) from None
        if ambient_text and not -60.0 <= ambient <= 60.0:
            raise BadInputError(f"{line}: ambient_c expected -60..60 °C, got {ambient:g}")
        path = _resolve(values["path"], base, is_path=True)
        real = _same_file_key(path)
        if real in seen:
            first, first_set = seen[real]
            sets = (
                f" under tyre sets {first_set!r} (row {first}) and {values['tyre_set_id']!r}"
                if first_set != values["tyre_set_id"]
                else ""
            )
            raise BadInputError(
                f"{line}: expected each log once, got {path} again (row {first}){sets}"
            )
        seen[real] = (i + 1, values["tyre_set_id"])
        items.append(
            DriveItem(
                drive_id=_drive_id(path),
                path=path,
                vehicle=_resolve(values["vehicle"], base, is_path=False),
                tyre_set_id=values["tyre_set_id"],
                tyre_type=values["tyre_type"],
                surface=surface,
                ambient_c=ambient,
                profile=_resolve(values["profile"], base, is_path=False),
            )
        )
    _check_one_type_per_set(items)
    return items


def _check_one_type_per_set(items: list[DriveItem]) -> None:
    """A tyre set has one tyre type: rows that name two are a contradiction, not a choice.

    A row without ``tyre_type`` takes the set's type from the rows that name it.
    """
    named: dict[str, tuple[str, int]] = {}
    for row, item in enumerate(items, start=1):
        if not item.tyre_type:
            continue
        first = named.setdefault(item.tyre_set_id, (item.tyre_type, row))
        if first[0] != item.tyre_type:
            raise BadInputError(
                f"manifest rows {first[1]} and {row}: expected one tyre_type per tyre set, got "
                f"tyre set {item.tyre_set_id!r} as {first[0]!r} (row {first[1]}) and "
                f"{item.tyre_type!r} (row {row})"
            )


def read_manifest(
    source: str | os.PathLike, *, vehicle: str | None = None, surface: str = DEFAULT_SURFACE
) -> list[DriveItem]:
    """The drives of a fleet run from a manifest file or a glob pattern.

    Parameters
    ----------
    source : path-like or str
        A manifest (``.csv``, ``.parquet``) or a glob pattern of logs (``*``, ``?`` or ``[``).
    vehicle : str, optional
        With a glob: the vehicle of every log (required); with a manifest: not allowed.
    surface : str
        With a glob: the surface of every drive.

    Raises
    ------
    BadInputError
        One line: no such manifest, unreadable table, a bad row, a glob without ``vehicle`` or
        matching nothing.

    Examples
    --------
    A manifest whose relative paths are taken from its folder:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     manifest = Path(folder) / "drives.csv"
    ...     pd.DataFrame({"path": ["a.parquet", "b.parquet"], "vehicle": "compact_fwd",
    ...                   "tyre_set_id": ["s1", "s2"], "surface": ["dry", "wet"]}).to_csv(
    ...         manifest, index=False)
    ...     items = read_manifest(manifest)
    ...     [(Path(d.path).name, d.tyre_set_id, d.surface) for d in items]
    [('a.parquet', 's1', 'dry'), ('b.parquet', 's2', 'wet')]

    A glob needs the vehicle of its logs:

    >>> from tyrebayes._resources import data_dir
    >>> items = read_manifest(str(data_dir() / "comma2k19*.csv"), vehicle="suv_rav4")
    >>> [(Path(d.path).name, d.tyre_set_id) for d in items]
    [('comma2k19_rav4_segment.csv', 'suv_rav4')]
    >>> read_manifest(str(data_dir() / "comma2k19*.csv"))
    Traceback (most recent call last):
    ...
    tyrebayes._errors.BadInputError: manifest glob '...': expected --vehicle for its logs, got none
    """
    text = str(source)
    if any(ch in text for ch in "*?["):
        if not vehicle:
            raise BadInputError(
                f"manifest glob {text!r}: expected --vehicle for its logs, got none"
            )
        paths = sorted(globlib.glob(os.path.expanduser(text), recursive=True))
        if not paths:
            raise BadInputError(f"manifest glob {text!r}: expected matching logs, got none")
        table = pd.DataFrame(
            {
                "path": paths,
                "vehicle": vehicle,
                "tyre_set_id": Path(vehicle).stem,
                "surface": surface,
            }
        )
        return manifest_from_table(table, Path.cwd())
    if vehicle:
        raise BadInputError("--vehicle: expected only with a glob of logs, got a manifest file")
    path = Path(text).expanduser()
    return manifest_from_table(_read_table(path), path.resolve().parent)
