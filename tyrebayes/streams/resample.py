"""Resampling a stream's channels onto one uniform time base, with short gaps bridged.

Each channel keeps its own valid instants (a wheel in its own CAN message, an IMU at another
rate); a gap longer than ``max_fill_s`` stays NaN. Called by
:func:`tyrebayes.streams.validate.validate_stream`.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Bool, Float

from .log_sample import sample_runs
from .order_stats import median as _median


def _median_interval(t: np.ndarray) -> float:
    """Median interval between consecutive time stamps, from runs of them on a long log
    (:mod:`.log_sample`)."""
    if t.size < 2:
        return float("nan")
    return _median(np.diff(sample_runs(t), axis=1).ravel(), overwrite_input=True)


def _resample_channel(
    grid: np.ndarray,
    t: np.ndarray,
    x: np.ndarray,
    max_fill_s: float,
    valid_time: np.ndarray | None = None,
    period: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Linear interpolation of one channel onto ``grid``; NaN across gaps longer than the limit.

    Returns the resampled values and a mask of grid points that fall in a bridged gap (an
    interval longer than 1.5 channel periods but within the fill limit). ``valid_time`` (the
    file instants where ``x`` has a value) and ``period`` (their median interval), when the
    caller has them, spare the passes over the whole channel: only the valid samples around
    the grid points are read.
    """
    if grid is t:
        return _fill_on_own_grid(t, x, np.isfinite(x), max_fill_s, period)
    if valid_time is None:
        valid = np.isfinite(x)
        tv, xv = t[valid], x[valid]
    else:
        tv, xv = valid_time, None
    out = np.full(grid.shape, np.nan)
    bridged = np.zeros(grid.shape, dtype=bool)
    if tv.size < 2:
        return out, bridged
    if period is None:
        period = _median_interval(tv)
    limit = max(max_fill_s, 1.5 * period)
    right = np.clip(np.searchsorted(tv, grid, side="left"), 1, tv.size - 1)
    if xv is None:
        # The valid instants around each grid point and their rows in the file: np.interp on
        # these knots alone brackets every grid point as it would on all of them.
        knots = np.unique(np.concatenate((right - 1, right)))
        values = np.interp(grid, tv[knots], x[np.searchsorted(t, tv[knots])])
    else:
        values = np.interp(grid, tv, xv)
    span = tv[right] - tv[right - 1]
    exact = (tv[right] == grid) | (tv[right - 1] == grid)
    inside = (grid >= tv[0]) & (grid <= tv[-1])
    ok = inside & (exact | (span <= limit * (1 + 1e-9)))
    out[ok] = values[ok]
    bridged = ok & ~exact & (span > 1.5 * period)
    return out, bridged


class _SharedSearch:
    """Where each grid point falls among the file's time stamps, computed once for all channels.

    Most channels hold a value at both file rows around a grid point; there a channel's own
    interval is the file's and the interpolation needs no search of its own.
    """

    def __init__(self, grid: np.ndarray, t: np.ndarray):
        # np.interp's interval: t[j] <= g < t[j + 1] (the last interval for g = t[-1]).
        j = np.searchsorted(t, grid, side="right")
        j -= 1
        self.j = np.clip(j, 0, t.size - 2, out=j)
        t0 = t.take(self.j)
        self.span = t[1:].take(self.j)  # t[j + 1], read through a shifted view
        self.span -= t0
        self.offset = np.subtract(grid, t0, out=t0)
        # Grid points on a file instant, and those at its last instant: few, so kept as
        # indices (the grid is sorted: the latter are one search).
        self.on_knot_index = np.flatnonzero(self.offset == 0.0)
        end = np.searchsorted(grid, t[-1], side="left"), np.searchsorted(grid, t[-1], "right")
        self.at_end_index = np.arange(*end)
        self.all_inside = bool(grid[0] >= t[0] and grid[-1] <= t[-1])
        self.inside = self.all_inside or (grid >= t[0]) & (grid <= t[-1])
        self.scratch = np.empty(grid.shape)  # one channel's x0, reused channel after channel
        # The longest file interval: when it is within a channel's fill limit (or below its
        # bridging threshold) that test holds for every grid point and needs no pass.
        self.max_span = float(self.span.max())

    @property
    def exact(self) -> np.ndarray:
        """Grid points on a file instant or at the last one (needed only where gaps are)."""
        exact = np.zeros(self.span.shape, dtype=bool)
        exact[self.on_knot_index] = True
        exact[self.at_end_index] = True
        return exact


def _resample_shared(
    grid: np.ndarray,
    t: np.ndarray,
    x: np.ndarray,
    max_fill_s: float,
    shared: _SharedSearch,
    period: float,
    valid_time: np.ndarray,
    out: np.ndarray,
) -> np.ndarray | None:
    """:func:`_resample_channel` on the file's intervals, the per-channel search only near NaN.

    Where the channel has values at both file rows around a grid point its interval is the
    file's, so the value is ``np.interp``'s own arithmetic there (the same to the last bit) and
    the gap tests are the file's interval against the channel's period. The few grid points next
    to a dropped sample (NaN here) go through :func:`_resample_channel`, which searches the
    channel's own valid instants (``valid_time``, with ``period`` their median interval).

    The values are written into ``out`` (the channel's row of the table); returns the bridged
    mask, or None where no grid point is bridged.
    """
    if valid_time.size < 2:
        out[:], bridged = _resample_channel(grid, t, x, max_fill_s)
        return bridged
    limit = max(max_fill_s, 1.5 * period)
    span = shared.span
    # np.interp's arithmetic, (x1 − x0) / span · offset + x0, in place in the output row.
    values = np.take(x[1:], shared.j, out=out, mode="clip")  # x[j + 1]; indices in range
    x0 = np.take(x, shared.j, out=shared.scratch, mode="clip")
    values -= x0
    values /= span
    values *= shared.offset
    values += x0
    values[shared.on_knot_index] = x0[shared.on_knot_index]
    values[shared.at_end_index] = x[-1]
    near_nan = ~np.isfinite(values)
    if not shared.all_inside:
        near_nan &= shared.inside
    if shared.max_span <= limit * (1 + 1e-9):
        ok = shared.inside  # every file interval within the fill limit
    else:
        ok = shared.inside & (shared.exact | (span <= limit * (1 + 1e-9)))
    if ok is not True:  # True: every grid point inside, every interval within the limit
        np.copyto(values, np.nan, where=~ok)
    bridged = None  # no file interval is a bridged gap
    if shared.max_span > 1.5 * period:
        bridged = ok & ~shared.exact & (span > 1.5 * period)
    if near_nan.any():
        idx = np.flatnonzero(near_nan)
        if bridged is None:
            bridged = np.zeros(span.shape, dtype=bool)
        values[idx], bridged[idx] = _resample_channel(
            grid[idx], t, x, max_fill_s, valid_time=valid_time, period=period
        )
    return bridged


def _fill_on_own_grid(
    t: np.ndarray, x: np.ndarray, valid: np.ndarray, max_fill_s: float, period: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_resample_channel` when the grid is the file's own time base (no search needed).

    Only the dropped samples need work: each is interpolated between its valid neighbours, found
    by one search over the (sorted) valid indices, so the cost is O(n) copies plus O(k log n) for
    k dropped samples.
    """
    out = x.copy()
    bridged = np.zeros(t.shape, dtype=bool)
    missing = np.flatnonzero(~valid)
    if missing.size == 0:
        return out, bridged
    kept = np.flatnonzero(valid)
    if kept.size == 0:
        return out, bridged  # all NaN already
    if period is None:
        period = _median_interval(t[kept])
    limit = max(max_fill_s, 1.5 * period) if np.isfinite(period) else max_fill_s
    after = np.searchsorted(kept, missing)  # index into kept of the next valid sample
    inside = (after > 0) & (after < kept.size)
    missing, after = missing[inside], after[inside]
    p, q = kept[after - 1], kept[after]
    span = t[q] - t[p]
    ok = span <= limit * (1 + 1e-9)
    missing, p, q, span = missing[ok], p[ok], q[ok], span[ok]
    out[missing] = x[p] + (x[q] - x[p]) * ((t[missing] - t[p]) / span)
    bridged[missing] = span > 1.5 * period
    return out, bridged


def _time_base(t: np.ndarray, dt: float) -> tuple[np.ndarray, bool]:
    """The file's own time stamps if they are uniform, else a uniform grid at the wheel rate."""
    steps = np.diff(t)
    if np.all(np.abs(steps - dt) <= 0.02 * dt):
        return t, False
    n = int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    return t[0] + dt * np.arange(n), True


def _runs(
    time: Float[np.ndarray, "n"], mask: Bool[np.ndarray, "n"]
) -> tuple[tuple[float, float], ...]:
    """(start, end) times of the contiguous True runs of ``mask``."""
    padded = np.concatenate(([False], mask, [False])).astype(np.int8)
    edges = np.diff(padded)
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    return tuple((float(time[s]), float(time[e])) for s, e in zip(starts, ends, strict=True))
