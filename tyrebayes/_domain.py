"""Domain knowledge defined once: tyre types, surfaces, gravity, vehicles, the measured data.

Everything the package knows about the world that is not a model lives here: the tyre types and
road surfaces (one order each), standard gravity, how a vehicle name becomes a vehicle file, and
the loaders of the measured tables shipped in ``tyrebayes/data`` and the reviewed numbers in
``models/``. Physics stays pure (no files); this module reads them.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

from ._resources import data_dir, models_dir
from .physics.vehicle import GRAVITY_MPS2, Vehicle, vehicle_from_mapping

#: Tyre types, in the order of every per-type array (fleet priors, wear types, verdicts).
TYRE_TYPES: tuple[str, ...] = ("winter", "all_season", "summer")
#: Road surfaces, in the order of every per-surface array.
SURFACES: tuple[str, ...] = ("snow", "ice", "wet", "dry")
#: Standard gravity [m/s²] (the physics' value; decelerations "in g" are in units of it).
GRAVITY = GRAVITY_MPS2
#: Friction coefficients a road tyre can have: above 0 (not even glare ice reaches it) and below
#: 2 (racing slicks on a warm track reach ~1.8). Outside is a sign or unit mistake (percent).
MU_RANGE: tuple[float, float] = (0.0, 2.0)
#: Stiffnesses a car tyre's C_xr can take: measured sets span 20-60 (thesis Table 6.2 and the
#: tyre-curve database); outside [1, 1000] a value is a unit or export mistake.
C_XR_RANGE: tuple[float, float] = (1.0, 1000.0)

__all__ = [
    "C_XR_RANGE",
    "GRAVITY",
    "MU_RANGE",
    "SURFACES",
    "TYRE_TYPES",
    "load_braking_data",
    "load_lane_change_speeds",
    "load_vehicle",
    "mean_deceleration_g",
    "read_toml",
    "vehicle_names",
    "vehicle_path",
]


def vehicle_names() -> list[str]:
    """The vehicle presets in ``models/vehicles/`` (file stems), sorted."""
    return sorted(p.stem for p in (models_dir() / "vehicles").glob("*.toml"))


def vehicle_path(name_or_path: str | Path) -> Path:
    """The vehicle file of a preset name (``"suv_rav4"``) or a path to a TOML file.

    Raises
    ------
    ValueError
        If no such file exists; the message lists the presets.
    """
    path = Path(name_or_path)
    if not path.suffix:
        path = models_dir() / "vehicles" / f"{name_or_path}.toml"
    if not path.is_file():
        raise ValueError(
            f"vehicle: expected a TOML file or one of {vehicle_names()}, got {str(name_or_path)!r}"
        )
    return path


def read_toml(path: str | Path) -> dict:
    """A TOML file as a dict; ``ValueError`` names the file when it is not valid TOML."""
    path = Path(path)
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"{path}: not valid TOML ({err})") from None


def load_vehicle(name_or_path: str | Path | Vehicle) -> Vehicle:
    """A :class:`~tyrebayes.physics.vehicle.Vehicle` from a preset name, a TOML path, or itself.

    Raises
    ------
    ValueError
        If the file does not exist, a required key is missing, a key is unknown, or a value is
        invalid; the message names the key and the value.

    Examples
    --------
    >>> load_vehicle("compact_fwd").drive
    'fwd'
    """
    if isinstance(name_or_path, Vehicle):
        return name_or_path
    path = vehicle_path(name_or_path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"vehicle file {path}: not valid TOML ({err})") from None
    return vehicle_from_mapping(data, source=f"vehicle file {path}")


def mean_deceleration_g(speed_kmh, distance_m):
    """Mean deceleration v² / (2 g d) of a stop from ``speed_kmh`` in ``distance_m`` [g]."""
    v = np.asarray(speed_kmh, float) / 3.6
    return v**2 / (2.0 * GRAVITY * np.asarray(distance_m, float))


def load_braking_data() -> pd.DataFrame:
    """Published braking distances by tyre type and surface (``braking_by_tyre_type.csv``).

    Columns ``source``, ``tyre_type``, ``surface``, ``speed_from_kmh``, ``distance_m`` (NaN where
    the source gives only a relation, in ``note``), ``note``; provenance in the data README.
    """
    return pd.read_csv(data_dir() / "braking_by_tyre_type.csv")


def load_lane_change_speeds(source: str | None = "thesis Table 6.2") -> pd.DataFrame:
    """Measured critical lane-change speeds (``critical_speed_lane_change.csv``) of one source.

    The default is the thesis' six ISO 3888-2 rows (tyre, tyre_type, c_xr, v_max_kmh); ``None``
    gives every row.
    """
    df = pd.read_csv(data_dir() / "critical_speed_lane_change.csv")
    if source is None:
        return df
    return df[df["source"] == source].reset_index(drop=True)
