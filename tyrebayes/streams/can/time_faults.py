"""Time faults of a CAN message: frames out of time order, duplicated frames, reversed logs.

A bus logger writes frames as it receives them, so a message's timestamps go forward in the file.
When they do not, something went wrong that the decoded signals would silently inherit:

* **out of order** — frames whose timestamp lies behind frames written before them: a logger's
  clock stepped back, buffers were flushed out of order, or files were concatenated. Sorting
  them in (what the converter did before) puts samples at instants they were not measured at
  when the timestamps themselves are wrong: 500 frames stamped 5 s early made wheel speeds jump
  by 2.9 rad/s and C_x 50.0 instead of 48.9;
* **duplicated** — the same frame (timestamp and payload) twice: a logger or a merge of two
  captures of one bus wrote it again;
* **reversed** — most steps go back: the log was written or exported backwards.

Neither python-can's readers (they yield frames in file order) nor asammdf (its signals assume
sorted timestamps; MDF4 marks a monotonic channel with a flag) repair this, so it is counted here,
per message, and either refused or repaired (:func:`repair_time_faults`): duplicates are dropped
(the first copy kept), a reversed message is sorted (its timestamps are right, its order is
not), and otherwise the frames out of order are dropped, keeping the longest run of the message
whose time goes forward (one glitch far into the future costs one frame, not every frame after
it). Two frames of a message at one instant with different payloads (``shared_timestamps``) are
counted but not a fault: comma's logs bundle frames at one timestamp; the later one is used.

Examples
--------
>>> import numpy as np
>>> t = np.array([0.0, 0.01, 0.02, 0.02, 0.005, 0.03])
>>> data = np.array([[1], [2], [3], [3], [9], [4]], dtype=np.uint8)
>>> faults, keep = repair_time_faults(t, data)
>>> faults.duplicates, faults.out_of_order, faults.reversed, keep.tolist()
(1, 1, False, [0, 1, 2, 5])
"""

from __future__ import annotations

import bisect
from dataclasses import asdict, dataclass

import numpy as np
from jaxtyping import Float, Int, UInt8

#: Default allowance: a message with more than this fraction of its frames duplicated or out of
#: order is refused (``--max-time-faults``).
DEFAULT_MAX_TIME_FAULTS = 0.01


@dataclass(frozen=True)
class TimeFaults:
    """What :func:`repair_time_faults` found in one message's frames.

    Attributes
    ----------
    frames : int
        Frames of the message, as read.
    duplicates : int
        Frames equal (timestamp and payload) to one written before them: dropped.
    out_of_order : int
        Frames (of the rest) off the longest run whose time goes forward; dropped, or sorted in
        when the message is reversed.
    reversed : bool
        More than half of the steps between frames go back in time.
    shared_timestamps : int
        Frames at the same instant as the one before them with another payload (not a fault).
    largest_backward_s : float
        The largest step back in time [s] (0 without one).
    """

    frames: int
    duplicates: int
    out_of_order: int
    reversed: bool
    shared_timestamps: int
    largest_backward_s: float

    @property
    def faulty(self) -> int:
        """Frames duplicated or out of order."""
        return self.duplicates + self.out_of_order

    @property
    def fraction(self) -> float:
        """:attr:`faulty` over :attr:`frames`."""
        return self.faulty / self.frames if self.frames else 0.0

    def as_dict(self) -> dict:
        return {**asdict(self), "fraction": self.fraction}

    def describe(self, message: str) -> str:
        """``WHEEL_SPEEDS: 125 of 6000 frames out of order (up to 5 s back), 3 duplicated``."""
        parts = []
        if self.out_of_order:
            parts.append(
                f"{self.out_of_order} of {self.frames} frames out of order"
                + (" (a reversed log?)" if self.reversed else "")
                + f" (up to {self.largest_backward_s:.3g} s back)"
            )
        if self.duplicates:
            parts.append(f"{self.duplicates} of {self.frames} frames duplicated")
        return f"{message}: {', '.join(parts)}" if parts else f"{message}: none"


def _longest_forward_run(t: np.ndarray) -> np.ndarray:
    """Indices of the longest subsequence of ``t`` that never goes back (ties allowed)."""
    tails: list[float] = []  # the smallest last value of a run of each length
    tail_index: list[int] = []
    previous = np.full(t.size, -1, dtype=np.int64)
    for i, value in enumerate(t.tolist()):
        k = bisect.bisect_right(tails, value)
        if k:
            previous[i] = tail_index[k - 1]
        if k == len(tails):
            tails.append(value)
            tail_index.append(i)
        else:
            tails[k] = value
            tail_index[k] = i
    run = []
    i = tail_index[-1] if tail_index else -1
    while i >= 0:
        run.append(i)
        i = int(previous[i])
    return np.asarray(run[::-1], dtype=np.int64)


def repair_time_faults(
    time_s: Float[np.ndarray, "n"], data: UInt8[np.ndarray, "n width"]
) -> tuple[TimeFaults, Int[np.ndarray, "m"]]:
    """Count one message's time faults and the frames to keep, in time order.

    Parameters
    ----------
    time_s : ndarray, shape (n,)
        The message's timestamps in file order [s].
    data : ndarray of uint8, shape (n, width)
        Its payloads.

    Returns
    -------
    (TimeFaults, ndarray of int)
        The counts, and indices into the frames: without duplicates, in forward time order.
    """
    n = int(time_s.size)
    steps = np.diff(time_s)
    shared = int(np.count_nonzero((steps == 0) & np.any(data[1:] != data[:-1], axis=1)))
    if n < 2 or np.all(steps > 0):
        # Forward already, no copies (the common case, without a search).
        return TimeFaults(n, 0, 0, False, shared, 0.0), np.arange(n, dtype=np.int64)
    back = np.maximum.accumulate(time_s)[:-1] - time_s[1:]
    largest_back = float(max(back.max(), 0.0))
    key = np.concatenate([time_s.astype(np.float64).view(np.uint8).reshape(n, 8), data], axis=1)
    _, first = np.unique(key, axis=0, return_index=True)
    unique = np.sort(first)  # the first copy of each frame, in file order
    duplicates = n - unique.size
    t = time_s[unique]
    u_steps = np.diff(t)
    reversed_ = u_steps.size > 0 and np.count_nonzero(u_steps < 0) > u_steps.size / 2
    if np.all(u_steps >= 0):
        keep, run_length = unique, unique.size  # only copies: no search for the order
    elif reversed_:
        keep = unique[np.argsort(t, kind="stable")]
        run_length = _longest_forward_run(t).size
    else:
        run = _longest_forward_run(t)
        keep = unique[run]
        run_length = run.size
    out_of_order = int(unique.size - run_length)
    faults = TimeFaults(n, int(duplicates), out_of_order, bool(reversed_), shared, largest_back)
    return faults, keep


__all__ = ["DEFAULT_MAX_TIME_FAULTS", "TimeFaults", "repair_time_faults"]
