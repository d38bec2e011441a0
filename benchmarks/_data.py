"""Where the benchmarks' measured and independent data come from: one loader per data set.

The data sit beside the repository in ``../shared/data`` (the package never reads them; only the
benchmarks and the tests do):

``external/``
    braking and traction drives from a generator written apart from the package, ``truth.json``
    with each drive's C_x and μ, and per-sample truth in ``drives/NAME_truth.parquet``;
``external_lateral/``
    cornering drives from another such generator, ``truth.json`` with each drive's c_y per
    axle, understeer gradient and μ_y;
``real/lateral/``
    real cornering logs with a measured lateral velocity (their README gives the sources).

Beside them, the data the package ships in ``tyrebayes/data/`` (read through
:func:`package_data_path`): the real RAV4 log (:func:`rav4_segment_path`, :func:`rav4_segment`)
and the ADAC wear
table (:func:`wear_by_tyre_type`). No benchmark reads a data file by any other path.

Each drive is a :class:`Drive`: its name, stream file, vehicle file and the generator's truth.
Scripts select drives by name (``--drives e00,e01``) with the ``names`` argument.

Examples
--------
>>> from benchmarks._data import external_lateral_drives
>>> drive = external_lateral_drives(names="l00")[0]  # doctest: +SKIP
>>> drive.name, drive.truth["kind"]  # doctest: +SKIP
('l00', 'mixed')
"""

from __future__ import annotations

import importlib.resources
import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import scipy.io

from tyrebayes import ValidatedStream, Vehicle, load_vehicle, read_stream, validate_stream

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = ROOT.parent / "shared" / "data"
EXTERNAL = SHARED_DATA / "external"
EXTERNAL_LATERAL = SHARED_DATA / "external_lateral"
REAL_LATERAL = SHARED_DATA / "real" / "lateral"


@dataclass(frozen=True)
class Drive:
    """One drive of an independent generator, with the truth it was made from.

    Attributes
    ----------
    name
        The stream file's stem (``e00``, ``l03``).
    path
        The stream file (Parquet, the package's stream schema).
    vehicle_path
        The vehicle file the generator used (TOML).
    truth
        The generator's truth for the drive, as its ``truth.json`` gives it.
    """

    name: str
    path: Path
    vehicle_path: Path
    truth: dict[str, Any] = field(repr=False)

    def vehicle(self) -> Vehicle:
        """The drive's vehicle."""
        return load_vehicle(self.vehicle_path)

    def validated(self, vehicle: Vehicle | None = None) -> ValidatedStream:
        """The stream, read and validated against the drive's vehicle (or ``vehicle``)."""
        return validate_stream(read_stream(self.path), vehicle or self.vehicle())

    def truth_samples_path(self) -> Path:
        """The per-sample truth beside the stream (``NAME_truth.parquet``)."""
        return self.path.with_name(f"{self.name}_truth.parquet")

    def truth_samples(self) -> pd.DataFrame:
        """The per-sample truth beside the stream, as the generator wrote it."""
        return pd.read_parquet(self.truth_samples_path())

    def frame(self) -> pd.DataFrame:
        """The stream file as it is (not validated): for a baseline that reads raw columns."""
        return pd.read_parquet(self.path)


def _wanted(names: str | Iterable[str]) -> set[str] | None:
    if isinstance(names, str):
        names = [n for n in names.split(",") if n]
    wanted = {Path(n).stem for n in names}
    return wanted or None


def _select(drives: list[Drive], names: str | Iterable[str]) -> list[Drive]:
    wanted = _wanted(names)
    if wanted is None:
        return drives
    unknown = wanted - {d.name for d in drives}
    if unknown:
        raise SystemExit(
            f"expected drive names among {sorted(d.name for d in drives)}, got {sorted(unknown)}"
        )
    return [d for d in drives if d.name in wanted]


def external_drives(folder: Path = EXTERNAL, names: str | Iterable[str] = "") -> list[Drive]:
    """The braking and traction drives of ``external/`` (all, or those named), in name order.

    Their ``truth.json`` is ``{"drives": [{"name", "vehicle", "c_x", "mu", ...}, ...]}``.
    """
    folder = Path(folder)
    entries = json.loads((folder / "truth.json").read_text())["drives"]
    drives = [
        Drive(
            name=e["name"],
            path=folder / "drives" / f"{e['name']}.parquet",
            vehicle_path=folder / "drives" / e["vehicle"],
            truth=e,
        )
        for e in sorted(entries, key=lambda e: e["name"])
    ]
    return _select(drives, names)


def external_lateral_drives(
    folder: Path = EXTERNAL_LATERAL, names: str | Iterable[str] = ""
) -> list[Drive]:
    """The cornering drives of ``external_lateral/`` (all, or those named), in name order.

    Their ``truth.json`` is ``{"l00.parquet": {"vehicle", "surface", "kind", "c_y_front", ...}}``.
    """
    folder = Path(folder)
    entries = json.loads((folder / "truth.json").read_text())
    drives = [
        Drive(
            name=Path(file).stem,
            path=folder / "drives" / file,
            vehicle_path=folder / "drives" / entry["vehicle"],
            truth=entry,
        )
        for file, entry in sorted(entries.items())
    ]
    return _select(drives, names)


def package_data_path(name: str) -> Path:
    """A data file the package ships in ``tyrebayes/data/`` (``name``: its file name)."""
    return Path(str(importlib.resources.files("tyrebayes").joinpath("data", name)))


def rav4_segment_path() -> Path:
    """The shipped real log: a 60 s comma2k19 RAV4 highway segment (the stream schema, CSV)."""
    return package_data_path("comma2k19_rav4_segment.csv")


def rav4_segment() -> pd.DataFrame:
    """The shipped real log as it is (not validated): :func:`rav4_segment_path`'s CSV."""
    return pd.read_csv(rav4_segment_path())


def wear_by_tyre_type() -> pd.DataFrame:
    """ADAC's measured tread wear by tyre type (``wear_by_tyre_type.csv``, shipped)."""
    return pd.read_csv(package_data_path("wear_by_tyre_type.csv"))


def stanford_lateral_log() -> pd.DataFrame:
    """Stanford's 2014 Leanza log (``real/lateral/stanford_2014_leanza``), 100 Hz.

    Columns: time, speed_reference, lateral_velocity (measured), yaw_rate, ay,
    wheel_angle_front (two one-sample spikes in delta removed and interpolated).
    """
    folder = REAL_LATERAL / "stanford_2014_leanza"

    def col(name):
        return np.loadtxt(folder / f"{name}.txt")

    delta = col("delta")
    # Two one-sample spikes to 0.48 rad (README): a road-wheel angle cannot jump so in 10 ms.
    jump = np.abs(np.diff(delta, prepend=delta[0])) > 0.1
    spikes = jump | np.roll(jump, -1)
    delta[spikes] = np.nan
    return pd.DataFrame(
        {
            "time": col("t"),
            "speed_reference": col("vx"),
            "lateral_velocity": col("vy"),
            "yaw_rate": col("yawRate"),
            "ay": col("ayCG"),
            "wheel_angle_front": pd.Series(delta).interpolate().to_numpy(),
        }
    )


def niki_lateral_log(name: str) -> pd.DataFrame:
    """One of the Niki GTI side-slip logs (``real/lateral/niki_gti_side_slip/NAME.mat``).

    The same columns as :func:`stanford_lateral_log`; ``High_Speed2`` is taken at its 200 Hz.
    """
    mat = scipy.io.loadmat(REAL_LATERAL / "niki_gti_side_slip" / f"{name}.mat")
    dt = 0.001 if name == "High_Speed2" else 0.005
    n = mat["Ux_mps"].size
    frame = pd.DataFrame(
        {
            "time": np.arange(n) * dt,
            "speed_reference": mat["Ux_mps"].ravel(),
            "lateral_velocity": mat["Uy_mps"].ravel(),
            "yaw_rate": mat["r_radps"].ravel(),
            "ay": mat["ay_mps2"].ravel(),
            "wheel_angle_front": mat["delta_rad"].ravel(),
        }
    )
    if name == "High_Speed2":  # each value held 5 samples at 1 kHz: the 200 Hz signal
        frame = frame.iloc[::5].reset_index(drop=True)
    return frame
