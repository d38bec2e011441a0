"""A CAN log, a DBC and a car profile in; a stream table in the DESIGN.md contract out.

Each profile message is decoded on its own time base (the frames' timestamps); the columns are
merged onto the union of those instants, NaN where a message was not sent, like an MDF4 logger
file, so that :func:`tyrebayes.streams.validate_stream` puts them onto one uniform time base with
its resampling. Time is counted from the first kept frame; the logged time of that frame is kept
as :attr:`CanConversion.time_origin_s`. A message whose timestamps do not go forward (frames out
of order, duplicated, a reversed log: :mod:`.time_faults`) is refused above an allowance
(``max_time_faults``, 1 % of its frames by default) and repaired below it, its counts kept in
:attr:`CanConversion.time_faults`.

Examples
--------
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "bus.log"
>>> _ = path.write_text("(5.000000) can0 0AA#417F417F417F417F\\n")  # 0x417F * 0.01 - 67.67 = 100
>>> conv = read_can_log(path, "toyota_rav4_2017", check_complete=False)
>>> round(float(conv.data["wheel_speed_fl"].iloc[0]) * 0.35 * 3.6, 2)  # back to km/h
100.0
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ..._errors import BadInputError
from .dbc import SignalLayout, decode_signal, load_dbc, signal_layout
from .frames import CanFrames, FrameCounts, read_frames
from .profile import CarProfile, ProfileChannel, load_profile
from .time_faults import DEFAULT_MAX_TIME_FAULTS, TimeFaults, repair_time_faults

if TYPE_CHECKING:
    from ..validate import ValidatedStream


@dataclass(frozen=True)
class BoundMessage:
    """A DBC message the profile uses, with the layouts of its signals."""

    name: str
    frame_id: int
    length: int
    signals: dict[str, SignalLayout]


@dataclass(frozen=True)
class CanConversion:
    """A decoded CAN log: the stream table and what was read.

    Attributes
    ----------
    data : pandas.DataFrame
        ``time`` [s from the first kept frame] and one column per profile channel in SI units, on
        the union of the messages' instants (NaN where a message was not sent). Not yet
        validated: pass it to :func:`tyrebayes.streams.validate_stream`.
    counts : FrameCounts
        Frames read, error and remote frames skipped, frames on other buses.
    frames_per_message : dict
        Message name -> frames decoded.
    invalid_per_column : dict
        Column -> samples set to NaN by the profile's ``invalid`` signals.
    time_origin_s : float
        Logged timestamp of the first kept frame [s].
    time_faults : dict
        Message name -> :class:`~.time_faults.TimeFaults` (what was repaired; all zero on a
        sound log).
    """

    data: pd.DataFrame
    counts: FrameCounts
    frames_per_message: dict[str, int]
    invalid_per_column: dict[str, int]
    time_origin_s: float
    time_faults: dict[str, TimeFaults] = field(default_factory=dict)

    @property
    def time_faults_repaired(self) -> int:
        """Frames dropped or put back in order over all messages (0 on a sound log)."""
        return sum(f.faulty for f in self.time_faults.values())

    def time_faults_text(self) -> str:
        """One line on what was repaired, for a warning (empty when nothing was)."""
        faulty = [f.describe(name) for name, f in self.time_faults.items() if f.faulty]
        return f"CAN time faults repaired: {'; '.join(faulty)}" if faulty else ""


def bind_profile(profile: CarProfile, db) -> dict[str, BoundMessage]:
    """The profile's messages looked up in the DBC (names expected vs found on a mismatch)."""
    bound: dict[str, BoundMessage] = {}
    for ch in profile.channels:
        if ch.message not in bound:
            try:
                msg = db.get_message_by_name(ch.message)
            except KeyError:
                names = sorted(m.name for m in db.messages)
                raise BadInputError(
                    f"profile {profile.name}: channel {ch.column} expects message "
                    f"{ch.message!r} in the DBC, got none of that name (DBC messages: "
                    f"{', '.join(names[:8])}{', ...' if len(names) > 8 else ''})"
                ) from None
            layouts = {s.name: signal_layout(s) for s in msg.signals if not s.multiplexer_ids}
            bound[ch.message] = BoundMessage(msg.name, int(msg.frame_id), int(msg.length), layouts)
        message = bound[ch.message]
        for name in ch.signals + ch.invalid:
            if name not in message.signals:
                multiplexed = [
                    s for s in db.get_message_by_name(ch.message).signals if s.name == name
                ]
                if multiplexed:
                    signal_layout(multiplexed[0])  # raises: multiplexed signals are refused
                raise BadInputError(
                    f"profile {profile.name}: channel {ch.column} expects signal {name!r} in "
                    f"message {ch.message}, got signals {sorted(message.signals)}"
                )
    return bound


def _check_range(values: np.ndarray, layout: SignalLayout, message: str, time_s: np.ndarray):
    limits = layout.checked_range()
    if limits is None:
        return
    lo, hi = limits
    slack = 0.5 * abs(layout.scale) + 1e-9 * max(abs(lo), abs(hi), 1.0)
    bad = (values < lo - slack) | (values > hi + slack)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise BadInputError(
            f"signal {layout.name} of {message}: expected values in the DBC range "
            f"[{lo:g}, {hi:g}], got {values[first]:g} in {int(bad.sum())} frame(s), the first at "
            f"{time_s[first]:.6f} s (wrong DBC or corrupt frames?)"
        )


def _decode_channel(
    ch: ProfileChannel, message: BoundMessage, data: np.ndarray, time_s: np.ndarray, radius: float
) -> tuple[np.ndarray, int]:
    total = np.zeros(data.shape[0])
    for name in ch.signals:
        layout = message.signals[name]
        values = decode_signal(data, layout)
        _check_range(values, layout, message.name, time_s)
        total += values
    column = total * ch.factor(radius)
    invalid = np.zeros(data.shape[0], dtype=bool)
    for name in ch.invalid:
        invalid |= decode_signal(data, message.signals[name]) != 0.0
    column[invalid] = np.nan
    return column, int(invalid.sum())


def _no_frames(path: Path, counts: FrameCounts, bound: dict[str, BoundMessage], bus: str):
    ids = ", ".join(f"{m.name} (0x{m.frame_id:X})" for m in bound.values())
    if counts.frames == 0:
        return BadInputError(
            f"CAN log {path.name}: expected data frames, got none ({counts.error_frames} error "
            f"and {counts.remote_frames} remote frames)"
        )
    if bus and counts.other_bus:
        return BadInputError(
            f"CAN log {path.name}: expected frames of {ids} on bus {bus!r}, got none on it; "
            f"they are on {list(counts.buses)}"
        )
    return BadInputError(
        f"CAN log {path.name}: expected frames of the profile's messages {ids}, got none of "
        f"them in {counts.frames} data frames (wrong profile, DBC or bus?)"
    )


def decode_frames(
    frames: CanFrames,
    bound: dict[str, BoundMessage],
    profile: CarProfile,
    wheel_radius_m: float,
    log_name: str = "log",
    max_time_faults: float = DEFAULT_MAX_TIME_FAULTS,
) -> tuple[
    dict[str, tuple[np.ndarray, np.ndarray]], dict[str, int], dict[str, int], dict[str, TimeFaults]
]:
    """Decode every profile channel on its message's timestamps (logged time, forward).

    Each message's time faults are counted and repaired (:func:`.time_faults.repair_time_faults`)
    when they are at most ``max_time_faults`` of its frames, and refused above. Returns the
    columns, the frames decoded per message, the invalid samples per column and the time faults
    per message.
    """
    columns: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    per_message: dict[str, int] = {}
    invalid: dict[str, int] = {}
    time_faults: dict[str, TimeFaults] = {}
    for message in bound.values():
        rows = np.flatnonzero(frames.arbitration_id == message.frame_id)
        if rows.size == 0:
            present = sorted({int(i) for i in np.unique(frames.arbitration_id)})
            raise BadInputError(
                f"CAN log {log_name}: expected frames of message {message.name} "
                f"(0x{message.frame_id:X}), got none (the profile's messages present: "
                f"{[f'0x{i:X}' for i in present]})"
            )
        on = frames.bus[rows]
        if on.size and on.min() != on.max():
            buses = [frames.bus_names[i] for i in np.unique(on)]
            raise BadInputError(
                f"CAN log {log_name}: expected message {message.name} (0x{message.frame_id:X}) "
                f"on one bus, got it on {buses} (a gateway mirrors it?): choose one with --bus "
                "or the profile's bus"
            )
        lengths = frames.length[rows]
        # Without the DLC in the log (comma raw_can) only bytes beyond the DBC's length show.
        wrong = lengths != message.length if frames.exact_length else lengths > message.length
        if wrong.any():
            got = sorted({int(n) for n in np.unique(lengths[wrong])})
            raise BadInputError(
                f"CAN log {log_name}: the DBC does not match: message {message.name} "
                f"(0x{message.frame_id:X}) has {message.length} bytes in the DBC, got "
                f"{int(wrong.sum())} of {rows.size} frames with "
                f"{'' if frames.exact_length else 'at least '}{got} bytes"
            )
        faults, keep = repair_time_faults(frames.time_s[rows], frames.data[rows])
        if faults.fraction > max_time_faults:
            raise BadInputError(
                f"CAN log {log_name}: expected timestamps that go forward, got "
                f"{faults.describe(message.name)}: {100 * faults.fraction:.3g} % of its frames, "
                f"above the {100 * max_time_faults:.3g} % allowed (max_time_faults; more "
                "would be repaired by dropping them, or sorting a reversed log)"
            )
        time_faults[message.name] = faults
        rows = rows[keep]
        t = frames.time_s[rows]
        data = frames.data[rows, : message.length]
        per_message[message.name] = int(rows.size)
        for ch in profile.channels:
            if ch.message != message.name:
                continue
            values, n_invalid = _decode_channel(ch, message, data, t, wheel_radius_m)
            columns[ch.column] = (t, values)
            invalid[ch.column] = n_invalid
    return columns, per_message, invalid, time_faults


def read_can_log(
    path: str | os.PathLike,
    profile: CarProfile | str | os.PathLike,
    *,
    dbc: str | os.PathLike | None = None,
    vehicle=None,
    bus: str | None = None,
    check_complete: bool = True,
    max_time_faults: float = DEFAULT_MAX_TIME_FAULTS,
) -> CanConversion:
    """Decode a CAN log into a stream table with a car profile.

    Parameters
    ----------
    path : path-like
        CAN log file, or a comma ``raw_can`` folder (see
        :func:`tyrebayes.streams.can.read_frames` for the formats).
    profile : CarProfile, str or path-like
        Profile, or a name in ``models/profiles/`` or a TOML path.
    dbc : path-like, optional
        DBC to use instead of the profile's.
    vehicle : Vehicle, str or path-like, optional
        Vehicle whose nominal wheel radius converts wheel speeds (default: the profile's).
    bus : str, optional
        Bus to use instead of the profile's (``""`` for every bus).
    check_complete : bool
        Require every profile message to be present (default). With False, messages with no frame
        in the log are left out instead.
    max_time_faults : float
        Fraction of a message's frames that may be out of time order or duplicated (default
        0.01): up to it they are dropped (a reversed message sorted) and counted in
        :attr:`CanConversion.time_faults`; above it the log is refused. 0 refuses any.

    Returns
    -------
    CanConversion

    Raises
    ------
    BadInputError
        An unreadable, truncated or garbled log; a profile message or signal missing from the
        DBC; no frames of the profile's messages (on the chosen bus); frames whose length differs
        from the DBC's; a signal outside its DBC range; a message with more time faults than
        ``max_time_faults`` allows.

    Examples
    --------
    Two wheel-speed frames of a RAV4 (candump text; raw 0x417F · 0.01 − 67.67 = 100 km/h):

    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> log = folder / "bus.log"
    >>> _ = log.write_text("(5.00) can0 0AA#417F417F417F417F\\n(5.01) can0 0AA#41A341A341A341A3\\n")
    >>> conv = read_can_log(log, "toyota_rav4_2017", check_complete=False)
    >>> list(conv.data.columns), conv.time_origin_s, conv.frames_per_message
    (['time', 'wheel_speed_fl', ...], 5.0, {'WHEEL_SPEEDS': 2})

    By default every message of the profile must be in the log:

    >>> read_can_log(log, "toyota_rav4_2017")
    Traceback (most recent call last):
    ...
    tyrebayes._errors.BadInputError: CAN log bus.log: expected frames of message KINEMATICS...
    """
    from ..._domain import load_vehicle
    from ..time_bases import merge_time_bases

    path = Path(path)
    if not 0.0 <= max_time_faults <= 1.0:
        raise BadInputError(
            f"max_time_faults: expected a fraction of a message's frames in [0, 1], "
            f"got {max_time_faults:g}"
        )
    if not isinstance(profile, CarProfile):
        profile = load_profile(profile)
    try:
        vehicle = load_vehicle(vehicle if vehicle is not None else profile.vehicle)
    except ValueError as err:
        raise BadInputError(str(err).splitlines()[0]) from None
    db = load_dbc(profile.dbc_path(dbc))
    bound = bind_profile(profile, db)
    bus = profile.bus if bus is None else bus
    frames, counts = read_frames(path, ids={m.frame_id for m in bound.values()}, bus=bus or None)
    if counts.kept == 0:
        raise _no_frames(path, counts, bound, bus)
    if not check_complete:
        present = set(np.unique(frames.arbitration_id).tolist())
        bound = {k: m for k, m in bound.items() if m.frame_id in present}
    columns, per_message, invalid, time_faults = decode_frames(
        frames, bound, profile, float(vehicle.wheel_radius_m), path.name, max_time_faults
    )
    # The first frame kept (a frame dropped as out of order may lie before it).
    origin = float(min(t[0] for t, _ in columns.values()))
    shifted = {name: (t - origin, x) for name, (t, x) in columns.items()}
    return CanConversion(
        data=merge_time_bases(shifted),
        counts=counts,
        frames_per_message=per_message,
        invalid_per_column=invalid,
        time_origin_s=origin,
        time_faults=time_faults,
    )


def validate_conversion(
    conversion: CanConversion, profile: CarProfile | str | os.PathLike, vehicle=None
) -> ValidatedStream:
    """Validate a decoded log; a refusal says which profile signals make the channels it names.

    :func:`tyrebayes.streams.validate_stream` names stream columns ("ax: expected the sign of the
    wheel speeds' dV_x/dt ..."); on a decoded log the fix is in the profile, so its one-line
    reason gains where each named column comes from.

    Parameters
    ----------
    conversion : CanConversion
        From :func:`read_can_log`.
    profile : CarProfile, str or path-like
        The profile it was decoded with.
    vehicle : Vehicle, optional
        Passed to :func:`tyrebayes.streams.validate_stream`.

    Returns
    -------
    ValidatedStream

    Raises
    ------
    BadInputError
        As :func:`tyrebayes.streams.validate_stream`, with
        ``(profile NAME: ax = -1 x KINEMATICS.ACCEL_X [m/s^2]; check its sign or unit)`` appended
        when the reason names profile channels.
    """
    from ..validate import validate_stream

    if not isinstance(profile, CarProfile):
        profile = load_profile(profile)
    try:
        return validate_stream(conversion.data, vehicle)
    except BadInputError as err:
        reason = str(err)
        # The channels a plausibility refusal is about come before its first colon.
        subject = reason.split(":", 1)[0]
        named = [ch for ch in profile.channels if re.search(rf"\b{ch.column}\b", subject)]
        if not named:
            raise
        where = "; ".join(
            f"{ch.column} = {ch.sign:+g} x {ch.message}.{'+'.join(ch.signals)} [{ch.unit}]"
            for ch in named
        )
        raise BadInputError(
            f"{reason} (profile {profile.name}: {where}; check "
            f"{'its' if len(named) == 1 else 'their'} sign or unit)"
        ) from None
