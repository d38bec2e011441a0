"""Raw CAN logs of a stream: encode its columns frame by frame with cantools and a car profile.

The inverse of :func:`tyrebayes.streams.can.read_can_log`, for tests and benchmarks: each row of a
stream table becomes one frame per profile message, encoded by cantools (``scaling=True``), with
the other signals of the message zero; the log is written by python-can's writers (the suffix
picks candump ``.log``, ``.asc``, ``.blf``, ``.csv``, ``.mf4``).

Examples
--------
>>> import numpy as np, pandas as pd
>>> from tyrebayes.streams.can import load_dbc, load_profile
>>> profile = load_profile("toyota_rav4_2017")
>>> db = load_dbc(profile.dbc_path())
>>> df = pd.DataFrame({"time": [0.0], "wheel_speed_fl": [10.0]})
>>> [hex(m.arbitration_id) for m in stream_messages(df, profile, db, wheel_radius_m=0.35)]
['0xaa', '0x24', '0x25', '0xb4']
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd


def _split_sum(total: float, scales: list[float]) -> list[float]:
    """Split a value into signals that are summed, coarse first (``STEER_ANGLE + FRACTION``).

    The last (finest) signal takes a remainder centred on zero, so a signed fine signal of
    ``ratio`` steps per coarse step never overflows.
    """
    if len(scales) == 1:
        return [total]
    if len(scales) != 2:
        raise ValueError(f"expected 1 or 2 summed signals, got {len(scales)}")
    coarse, fine = scales
    ratio = round(coarse / fine)
    if not math.isclose(ratio * fine, coarse, rel_tol=1e-9):
        raise ValueError(f"expected the coarse scale a multiple of the fine, got {scales}")
    steps = round(total / fine)
    k = math.floor((steps + ratio // 2) / ratio)
    return [k * coarse, (steps - k * ratio) * fine]


def stream_messages(
    df: pd.DataFrame,
    profile,
    db,
    *,
    wheel_radius_m: float,
    start_s: float = 0.0,
    every: Mapping[str, int] | None = None,
    channel: str | int = 0,
) -> list:
    """python-can messages of a stream table, one per row and profile message.

    Parameters
    ----------
    df : pandas.DataFrame
        ``time`` [s] and stream columns in SI units (columns the profile lacks are ignored; a
        profile column missing from ``df`` is encoded as 0 in its DBC unit).
    profile : CarProfile
        The car profile.
    db : cantools Database
        The DBC.
    wheel_radius_m : float
        Nominal wheel radius for wheel-speed units [m].
    start_s : float
        Added to ``time`` for the frames' timestamps [s].
    every : mapping, optional
        Message name -> keep one row in this many (a slower message).
    channel : str or int
        Bus written in each message.
    """
    import can

    every = dict(every or {})
    by_message: dict[str, list] = {}
    for ch in profile.channels:
        by_message.setdefault(ch.message, []).append(ch)
    time = df["time"].to_numpy(dtype=float)
    messages = []
    encoders = {name: db.get_message_by_name(name) for name in by_message}
    columns = {c: df[c].to_numpy(dtype=float) for c in df.columns if c != "time"}
    for i in range(time.size):
        for name, channels in by_message.items():
            if i % every.get(name, 1):
                continue
            msg = encoders[name]
            values = {s.name: 0.0 for s in msg.signals}
            for ch in channels:
                x = columns.get(ch.column)
                value = 0.0 if x is None else x[i] / ch.factor(wheel_radius_m)
                scales = [msg.get_signal_by_name(s).scale for s in ch.signals]
                for sig, part in zip(ch.signals, _split_sum(value, scales), strict=True):
                    values[sig] = part
            data = msg.encode(values, scaling=True, padding=False, strict=False)
            messages.append(
                can.Message(
                    timestamp=float(start_s + time[i]),
                    arbitration_id=msg.frame_id,
                    is_extended_id=msg.is_extended_frame,
                    data=data,
                    channel=channel,
                )
            )
    return messages


def write_can_log(messages, path: str | os.PathLike) -> Path:
    """Write python-can messages with the writer for the suffix (``can.Logger``)."""
    import can

    path = Path(path)
    with can.Logger(str(path)) as writer:
        for msg in messages:
            writer.on_message_received(msg)
    return path


def quantisation_si(profile, db, wheel_radius_m: float) -> dict[str, float]:
    """Per column, the DBC resolution of its finest signal in SI units (the round trip's bound)."""
    out = {}
    for ch in profile.channels:
        msg = db.get_message_by_name(ch.message)
        finest = min(abs(msg.get_signal_by_name(s).scale) for s in ch.signals)
        out[ch.column] = float(np.abs(finest * ch.factor(wheel_radius_m)))
    return out
