"""Car profiles: which DBC message and signals give each stream column, in which unit.

A profile is a TOML file, ``models/profiles/NAME.toml`` or any path::

    name = "toyota_rav4_2017"
    description = "2017-2019 Toyota RAV4 powertrain bus"
    vehicle = "suv_rav4"            # preset in models/vehicles/ (or a TOML path): nominal radius
    dbc = "toyota_new_mc_pt.dbc"    # beside the profile, else in models/dbc/
    bus = ""                        # keep frames of this bus only ("can0"; "" = every bus)

    [channels.wheel_speed_fl]       # a stream column (DESIGN.md contract)
    message = "WHEEL_SPEEDS"        # DBC message name
    signals = ["WHEEL_SPEED_FL"]    # summed when several, e.g. ["STEER_ANGLE", "STEER_FRACTION"]
    unit = "km/h"                   # unit of the DBC values (after the DBC's scale and offset)
    sign = 1                        # -1 turns the DBC's direction into ISO 8855 (left positive)
    invalid = ["WHEEL_SPEED_FL_FAULT"]  # signals whose non-zero value marks the sample invalid

Units: ``km/h``, ``m/s``, ``mph`` (speeds; for a wheel speed column divided by the vehicle's
nominal wheel radius to give rad/s), ``rad/s``, ``deg/s``, ``rpm``, ``rad``, ``deg``, ``m/s^2``,
``g``, ``degC``. All signals of one column come from one message, so that they are summed frame
by frame.

Examples
--------
>>> profile = load_profile("toyota_rav4_2017")
>>> profile.channel("steering_wheel_angle").signals
('STEER_ANGLE', 'STEER_FRACTION')
"""

from __future__ import annotations

import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..._errors import BadInputError
from ..._resources import models_dir
from ..schema import CHANNELS, WHEEL_COLUMNS

#: Unit name -> (quantity, factor to SI).
UNITS: dict[str, tuple[str, float]] = {
    "km/h": ("speed", 1.0 / 3.6),
    "m/s": ("speed", 1.0),
    "mph": ("speed", 0.44704),
    "rad/s": ("rate", 1.0),
    "deg/s": ("rate", math.pi / 180.0),
    "rpm": ("rate", 2.0 * math.pi / 60.0),
    "rad": ("angle", 1.0),
    "deg": ("angle", math.pi / 180.0),
    "m/s^2": ("acceleration", 1.0),
    "m/s²": ("acceleration", 1.0),
    "g": ("acceleration", 9.80665),
    "degC": ("temperature", 1.0),
}
# The quantity each contract unit measures.
_QUANTITY = {"rad/s": "rate", "rad": "angle", "m/s^2": "acceleration", "m/s": "speed"}
_QUANTITY["degC"] = "temperature"


@dataclass(frozen=True)
class ProfileChannel:
    """How one stream column is made from DBC signals.

    Parameters
    ----------
    column : str
        Stream column (DESIGN.md contract), e.g. ``"wheel_speed_fl"``.
    message : str
        DBC message name.
    signals : tuple of str
        Signals of that message, summed (in their DBC unit).
    unit : str
        Unit of the DBC values, a key of :data:`UNITS`.
    sign : float
        +1 or -1, applied after the unit conversion.
    invalid : tuple of str
        Signals of the same message whose non-zero value marks the sample invalid (NaN).
    """

    column: str
    message: str
    signals: tuple[str, ...]
    unit: str
    sign: float = 1.0
    invalid: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        spec = CHANNELS.get(self.column)
        if spec is None or self.column == "time":
            known = [c for c in CHANNELS if c != "time"]
            raise BadInputError(
                f"profile channel: expected a stream column in {known}, got {self.column!r}"
            )
        if not self.signals or not all(isinstance(s, str) and s for s in self.signals):
            raise BadInputError(
                f"profile channel {self.column}: expected a list of signal names, "
                f"got {list(self.signals)!r}"
            )
        if self.unit not in UNITS:
            raise BadInputError(
                f"profile channel {self.column}: expected a unit in {list(UNITS)}, "
                f"got {self.unit!r}"
            )
        if self.sign not in (1.0, -1.0):
            raise BadInputError(
                f"profile channel {self.column}: expected sign 1 or -1, got {self.sign!r}"
            )
        have = UNITS[self.unit][0]
        want = _QUANTITY[spec.unit]
        wheel_speed = self.column in WHEEL_COLUMNS and have == "speed"
        if have != want and not wheel_speed:
            raise BadInputError(
                f"profile channel {self.column}: expected a unit of {want} (the column is in "
                f"{spec.unit}), got {self.unit!r} ({have})"
            )

    def factor(self, wheel_radius_m: float) -> float:
        """Multiplier from the summed DBC value to the column's SI unit, sign included."""
        quantity, to_si = UNITS[self.unit]
        if quantity == "speed" and self.column in WHEEL_COLUMNS:
            to_si /= wheel_radius_m  # a wheel's circumferential speed to its angular speed
        return self.sign * to_si


@dataclass(frozen=True)
class CarProfile:
    """A car's profile: vehicle preset, DBC and how to make each stream column.

    Parameters
    ----------
    name : str
        Profile name.
    description : str
        What car and bus it is for.
    vehicle : str
        Vehicle preset name or TOML path (its nominal wheel radius converts wheel speeds).
    dbc : str
        DBC file: absolute, or a name resolved beside the profile and then in ``models/dbc/``.
    bus : str
        Bus whose frames are used, as the log reader names it; ``""`` for every bus.
    channels : tuple of ProfileChannel
        One entry per stream column.
    source : str
        Where the profile was read from (for messages).
    """

    name: str
    description: str
    vehicle: str
    dbc: str
    channels: tuple[ProfileChannel, ...]
    bus: str = ""
    source: str = field(default="")

    def __post_init__(self) -> None:
        columns = [c.column for c in self.channels]
        if not columns:
            raise BadInputError(f"profile {self.name}: expected [channels.*] tables, got none")
        dup = sorted({c for c in columns if columns.count(c) > 1})
        if dup:
            raise BadInputError(f"profile {self.name}: expected each column once, got {dup} twice")

    def channel(self, column: str) -> ProfileChannel:
        """The entry for ``column``."""
        for ch in self.channels:
            if ch.column == column:
                return ch
        raise KeyError(column)

    def dbc_path(self, override: str | os.PathLike | None = None) -> Path:
        """The DBC file to use: ``override`` if given, else the profile's."""
        if override is not None:
            return Path(override)
        candidates = [Path(self.dbc)]
        if self.source:
            candidates.append(Path(self.source).parent / self.dbc)
        candidates.append(models_dir() / "dbc" / self.dbc)
        for path in candidates:
            if path.is_file():
                return path
        raise BadInputError(
            f"profile {self.name}: expected its DBC {self.dbc!r} beside the profile or in "
            f"{models_dir() / 'dbc'}, got no such file (give one with --dbc)"
        )


_TOP_KEYS = {"name", "description", "vehicle", "dbc", "bus", "channels"}
_CHANNEL_KEYS = {"message", "signals", "unit", "sign", "invalid"}


def _channel(name: str, column: str, table: object) -> ProfileChannel:
    if not isinstance(table, dict):
        raise BadInputError(f"profile {name}: expected [channels.{column}] to be a table")
    unknown = sorted(set(table) - _CHANNEL_KEYS)
    if unknown:
        raise BadInputError(
            f"profile {name}: channels.{column}: expected keys {sorted(_CHANNEL_KEYS)}, "
            f"got unknown {unknown}"
        )
    for key in ("message", "signals", "unit"):
        if key not in table:
            raise BadInputError(f"profile {name}: channels.{column}: missing key {key!r}")
    signals = table["signals"]
    signals = (signals,) if isinstance(signals, str) else tuple(signals)
    invalid = table.get("invalid", ())
    invalid = (invalid,) if isinstance(invalid, str) else tuple(invalid)
    return ProfileChannel(
        column=column,
        message=str(table["message"]),
        signals=signals,
        unit=str(table["unit"]),
        sign=float(table.get("sign", 1.0)),
        invalid=invalid,
    )


def load_profile(name_or_path: str | os.PathLike) -> CarProfile:
    """Load a car profile: a name in ``models/profiles/`` or a TOML path.

    Parameters
    ----------
    name_or_path : str or path-like
        A profile name (``toyota_rav4_2017``) or the path of a profile TOML file.

    Returns
    -------
    CarProfile

    Examples
    --------
    >>> profile = load_profile("toyota_rav4_2017")
    >>> profile.vehicle, profile.dbc, profile.channels[0].column
    ('suv_rav4', 'toyota_new_mc_pt.dbc', 'wheel_speed_fl')

    Raises
    ------
    BadInputError
        Missing file, invalid TOML, a missing or unknown key, an unknown column or unit.
    """
    path = Path(name_or_path)
    if not path.suffix:
        path = models_dir() / "profiles" / f"{name_or_path}.toml"
    if not path.is_file():
        presets = sorted(p.stem for p in (models_dir() / "profiles").glob("*.toml"))
        raise BadInputError(
            f"profile: expected a TOML file or one of {presets}, got {str(name_or_path)!r}"
        )
    try:
        data = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise BadInputError(f"profile {path.name}: not valid TOML ({err})") from None
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise BadInputError(
            f"profile {path.name}: expected keys {sorted(_TOP_KEYS)}, got unknown {unknown}"
        )
    for key in ("vehicle", "dbc", "channels"):
        if key not in data:
            raise BadInputError(f"profile {path.name}: missing key {key!r}")
    name = str(data.get("name", path.stem))
    channels = data["channels"]
    if not isinstance(channels, dict):
        raise BadInputError(f"profile {path.name}: expected [channels.COLUMN] tables")
    return CarProfile(
        name=name,
        description=str(data.get("description", "")),
        vehicle=str(data["vehicle"]),
        dbc=str(data["dbc"]),
        bus=str(data.get("bus", "")),
        channels=tuple(_channel(name, col, table) for col, table in channels.items()),
        source=str(path.resolve()),
    )
