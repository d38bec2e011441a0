"""The frame table every CAN reader returns, and the counts of what it found.

Its own module so that the readers (:mod:`.candump`, :mod:`.comma`, python-can's in
:mod:`.frames`) import it from below, and :func:`.frames.read_frames` can dispatch to them
without an import circle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from jaxtyping import Float, Int, UInt8


@dataclass(frozen=True)
class CanFrames:
    """Data frames of a log, in file order.

    Attributes
    ----------
    time_s : ndarray of float64, shape (n,)
        Timestamps as logged [s] (epoch seconds for candump and BLF, seconds from the start of the
        measurement for ASC).
    arbitration_id : ndarray of int64, shape (n,)
        CAN identifiers (11 or 29 bit, without flags).
    data : ndarray of uint8, shape (n, width)
        Payloads, zero-padded to the longest kept frame.
    length : ndarray of int64, shape (n,)
        Payload length of each frame [bytes].
    bus : ndarray of int64, shape (n,)
        Bus of each frame, an index into ``bus_names``.
    bus_names : tuple of str
        The buses, as the reader names them.
    exact_length : bool
        Whether ``length`` is the logged DLC. False where the log does not store it (comma
        raw_can drops trailing zero bytes): ``length`` then counts the bytes up to the last
        non-zero one, a lower bound on the DLC.
    """

    time_s: Float[np.ndarray, "n"]
    arbitration_id: Int[np.ndarray, "n"]
    data: UInt8[np.ndarray, "n width"]
    length: Int[np.ndarray, "n"]
    bus: Int[np.ndarray, "n"]
    bus_names: tuple[str, ...]
    exact_length: bool = True


@dataclass(frozen=True)
class FrameCounts:
    """What a reader found in a log.

    Attributes
    ----------
    frames : int
        Data frames read (every identifier, every bus).
    error_frames, remote_frames : int
        Error and remote (RTR) frames, skipped.
    kept : int
        Data frames with a wanted identifier on the chosen bus.
    other_bus : int
        Data frames with a wanted identifier on another bus than the chosen one.
    buses : tuple of str
        The buses the frames with a wanted identifier were logged on, as the reader names them
        (``can0`` in candump, ``0``, ``1``... counted from 0 by python-can for ASC and BLF).
    """

    frames: int
    error_frames: int
    remote_frames: int
    kept: int
    other_bus: int
    buses: tuple[str, ...]


def empty_frames() -> CanFrames:
    """A frame table with no rows."""
    none = np.zeros(0, np.int64)
    return CanFrames(np.zeros(0), none, np.zeros((0, 8), np.uint8), none, none, ())
