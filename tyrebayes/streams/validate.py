"""Validate a stream table and put it on one uniform time base.

Every problem that would make the pipeline's answer wrong raises
:class:`tyrebayes.BadInputError` with one line naming what was expected and what was found:
missing required columns, text in numeric columns, missing/duplicated/decreasing time, too few
samples, all-NaN or constant (stuck) channels, values outside the physical range of the unit, and
unit mistakes caught by plausibility (wheel speeds in km/h, m/s or rpm instead of rad/s, steering
in degrees instead of rad), and contradictions between channels that stay inside every range
(``ax`` against the wheel speeds' dV_x/dt, time stamps in milliseconds, steering against yaw rate;
:mod:`tyrebayes.streams.plausibility`). Dropped samples (NaN) and gaps are not errors: short gaps
are bridged by linear interpolation and flagged, long gaps stay NaN; a low sample rate, long gaps
and many dropped samples are recorded in :attr:`ValidatedStream.flags`.

Examples
--------
>>> import numpy as np, pandas as pd
>>> t = np.arange(300) * 0.01
>>> df = pd.DataFrame({"time": t, "ax": 0.1 * np.sin(t)})
>>> try:
...     validate_stream(df)
... except BadInputError as err:
...     print(str(err)[:41])
missing required columns ['wheel_speed_fl
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from jaxtyping import Bool, Float

from .._errors import BadInputError
from ..physics.vehicle import Vehicle
from .filters import nan_moving_average, smoothed_derivative, window_samples
from .noise import quantisation_step, white_noise_sd
from .order_stats import median as _median
from .order_stats import nanmedian
from .plausibility import (
    check_ax_sign,
    check_lateral_signs,
    check_steering_scale,
    check_time_base,
    dropped_fraction,
    sampling_flags,
)
from .schema import CHANNELS, MIN_SAMPLES, OPTIONAL_COLUMNS, REQUIRED_COLUMNS, WHEEL_COLUMNS

# Defaults when no vehicle is given: a mid-size car.
_DEFAULT_RADIUS_M = 0.32
_DEFAULT_WHEELBASE_M = 2.7
_DEFAULT_STEERING_RATIO = 15.0
_KMH_PER_MPS = 3.6
_RPM_PER_RADPS = 60.0 / (2.0 * np.pi)
# Wheel radius vs GNSS: tyre size, wear and pressure change the rolling radius by a few percent.
_SCALE_TOLERANCE = 0.07


@dataclass(frozen=True)
class ValidatedStream:
    """A validated stream on a uniform time base, with what was found and done on the way.

    Attributes
    ----------
    data : pandas.DataFrame
        Uniform time base (``time`` [s]), contract columns in SI units and ISO 8855 axes, extra
        numeric columns kept. NaN where a channel has a gap longer than the fill limit.
    sample_rate_hz : float
        Rate of the uniform time base (the wheel-speed rate of the file) [Hz].
    filled : ndarray of bool, shape (n,)
        Samples where a required channel was bridged over a dropped sample by interpolation.
    nan_fraction : dict
        Per channel, the fraction of file rows without a value (dropped samples; for a channel
        logged at a lower rate than the table, also the rows it was not sampled in).
    channel_rate_hz : dict
        Per channel, the median rate of its valid samples in the file [Hz].
    quantisation : dict
        Per channel, the quantisation step found in the raw values (0.0 = continuous) [unit].
    noise : dict
        Per channel, the white-noise sd of the raw samples (quantisation included) [unit].
    gaps : tuple of (float, float)
        Intervals [s] where the wheel speeds have no data after gap filling.
    resampled : bool
        True if the file's time stamps were irregular or multi-rate and were interpolated.
    notes : tuple of str
        Conversions and decisions made (IMU frame flip, dropped empty optional channels).
    flags : tuple of str
        Judgements on the data that make answers from it less certain than they look (sample
        rate below 20 Hz, gaps of 10 s or more, a required channel with over 20 % of its samples
        dropped); one line each, shown by ``inspect``.
    """

    data: pd.DataFrame
    sample_rate_hz: float
    filled: Bool[np.ndarray, "n"]
    nan_fraction: dict[str, float]
    channel_rate_hz: dict[str, float]
    quantisation: dict[str, float]
    noise: dict[str, float]
    gaps: tuple[tuple[float, float], ...]
    resampled: bool
    notes: tuple[str, ...] = field(default=())
    flags: tuple[str, ...] = field(default=())

    @property
    def duration_s(self) -> float:
        """Span of the time base [s]."""
        t = self.data["time"].to_numpy()
        return float(t[-1] - t[0])

    def mean_ambient_c(self, default: float = 20.0) -> float:
        """Mean of the ``ambient_temperature`` column [°C], or ``default`` without one."""
        if "ambient_temperature" in self.data:
            ambient = self.data["ambient_temperature"].to_numpy(dtype=float)
            if np.isfinite(ambient).any():
                return float(np.nanmean(ambient))
        return float(default)


def _check_columns(df: pd.DataFrame) -> None:
    missing = [c for c in REQUIRED_COLUMNS if c not in df.columns]
    if missing:
        raise BadInputError(
            f"missing required columns {missing}: expected {list(REQUIRED_COLUMNS)}, "
            f"got {[str(c) for c in df.columns][:12]}"
        )


def _numeric_columns(df: pd.DataFrame) -> dict[str, np.ndarray]:
    """Contract columns as float arrays (text in a contract column is an error); numeric extras."""
    out: dict[str, np.ndarray] = {}
    for name in df.columns:
        col = df[name]
        contract = name in CHANNELS
        if name == "time" and pd.api.types.is_datetime64_any_dtype(col):
            # Logger time stamps as datetimes: seconds since the epoch (NaT stays NaN).
            seconds = col.astype("int64").to_numpy() / 1e9
            out["time"] = np.where(col.isna().to_numpy(), np.nan, seconds)
            continue
        if pd.api.types.is_bool_dtype(col) or not pd.api.types.is_numeric_dtype(col):
            if not contract:
                continue  # text extras are kept out of the numeric pipeline
            converted = pd.to_numeric(col, errors="coerce")
            bad = converted.isna() & col.notna()
            if bad.any():
                example = col[bad].iloc[0]
                raise BadInputError(
                    f"column '{name}': expected numbers in {CHANNELS[name].unit}, got text like "
                    f"{str(example)[:20]!r}"
                )
            col = converted
        out[str(name)] = col.to_numpy(dtype=float, na_value=np.nan)
    return out


def _infinite_as_dropped(cols: dict[str, np.ndarray], notes: list[str]) -> None:
    """±inf in a channel becomes NaN, a dropped sample, with a note of how many.

    A logger or decoder writes inf for a value it could not form (a division by a zero
    count, an overflowed scaling); no sensor measures it. Left in, it would pass for a value in
    the differences and medians downstream and turn them to NaN there, unannounced.
    """
    for name, x in cols.items():
        if name == "time":
            continue
        infinite = np.isinf(x)
        count = int(np.count_nonzero(infinite))
        if count:
            cols[name] = np.where(infinite, np.nan, x)
            notes.append(f"column '{name}': {count} infinite values read as dropped samples")


def _check_time(t: np.ndarray) -> None:
    if not np.all(np.isfinite(t)):
        row = int(np.flatnonzero(~np.isfinite(t))[0])
        raise BadInputError(
            f"time: expected a finite value in every row, got {t[row]} at row {row}"
        )
    dt = np.diff(t)
    if np.any(dt == 0.0):
        row = int(np.flatnonzero(dt == 0.0)[0])
        raise BadInputError(
            f"time: expected strictly increasing values, got duplicated time {t[row]:.6g} s at "
            f"rows {row} and {row + 1}"
        )
    if np.any(dt < 0.0):
        row = int(np.flatnonzero(dt < 0.0)[0])
        raise BadInputError(
            f"time: expected strictly increasing values, got {t[row + 1]:.6g} s after "
            f"{t[row]:.6g} s at row {row + 1} (non-monotonic)"
        )


def _unit_hint(name: str, worst: float) -> str:
    if name == "steering_wheel_angle" or name.startswith("wheel_angle"):
        return " (looks like degrees)"
    if name.startswith("wheel_speed") or name == "engine_speed":
        return " (looks like rpm)" if worst > 500 else ""
    if name == "time":
        return ""
    if name in ("ax", "ay", "az"):
        return " (looks like mg or cm/s²)" if abs(worst) > 100 else ""
    if name == "yaw_rate":
        return " (looks like deg/s)"
    return ""


def _finite_range(x: np.ndarray) -> tuple[float, float]:
    """Smallest and largest finite value of ``x`` (NaN, NaN if it has none)."""
    # fmin/fmax skip NaN in one pass each; only an infinity needs the finite values picked out.
    lo, hi = float(np.fmin.reduce(x)), float(np.fmax.reduce(x))
    if np.isinf(lo) or np.isinf(hi):
        finite = x[np.isfinite(x)]
        if finite.size == 0:
            return float("nan"), float("nan")
        lo, hi = float(finite.min()), float(finite.max())
    return lo, hi


def _check_ranges(cols: dict[str, np.ndarray], bounds: dict[str, tuple[float, float]]) -> None:
    for name in cols:
        spec = CHANNELS.get(name)
        if spec is None or name == "time":
            continue
        lo, hi = bounds[name]
        if np.isnan(lo):
            continue
        if lo < spec.lo or hi > spec.hi:
            worst = hi if hi > spec.hi else lo
            raise BadInputError(
                f"column '{name}': expected values in [{spec.lo:g}, {spec.hi:g}] {spec.unit}, "
                f"got {worst:.6g}{_unit_hint(name, worst)}"
            )


def _check_channels(
    cols: dict[str, np.ndarray], bounds: dict[str, tuple[float, float]], notes: list[str]
) -> None:
    for name in REQUIRED_COLUMNS[1:]:
        lo, hi = bounds[name]
        if np.isnan(lo):
            raise BadInputError(f"column '{name}': expected measured values, got only NaN")
        if lo == hi:  # every finite value the same
            first = float(cols[name][np.isfinite(cols[name])][0])
            if name == "steering_wheel_angle" and _drives_straight(cols["yaw_rate"]):
                # A coarse CAN steering angle (0.5-1.5 degree steps) can stay on one step over a
                # straight stretch: not a stuck sensor as long as the car does not turn either.
                notes.append(
                    f"steering_wheel_angle is constant ({first:.4g} rad) on a straight drive"
                )
                continue
            raise BadInputError(
                f"column '{name}': expected a varying signal, got the constant {first:.6g} "
                "(stuck or unconnected sensor?)"
            )
    for name in OPTIONAL_COLUMNS:
        if name in cols and np.isnan(bounds[name][0]):
            del cols[name]
            notes.append(f"optional column '{name}' holds only NaN and was dropped")


def _drives_straight(yaw_rate: np.ndarray) -> bool:
    """Yaw rate within ±0.02 rad/s (1.1 deg/s) of its median for 99 % of the log."""
    finite = yaw_rate[np.isfinite(yaw_rate)]
    if finite.size == 0:
        return False
    return bool(np.quantile(np.abs(finite - np.median(finite)), 0.99) < 0.02)


def _fix_imu_frame(cols: dict[str, np.ndarray], notes: list[str]) -> None:
    """An IMU logged with z down (aerospace body frame) reads az ≈ -g at rest: turn it to ISO."""
    az = cols.get("az")
    if az is None:
        return
    median = nanmedian(az)
    if median < -5.0:
        for name in ("ay", "yaw_rate", "az"):
            cols[name] = -cols[name]
        notes.append(
            f"IMU frame is z-down (median az = {median:.2f} m/s²): ay, yaw_rate and az negated "
            "to ISO 8855 (z up, left positive)"
        )


def median_of_four(x: Float[np.ndarray, "n 4"]) -> Float[np.ndarray, "n"]:
    """Row-wise median of four columns, (sum − min − max) / 2 (NaN if any is NaN).

    Column by column: a reduction along a row of four is ~10x slower in NumPy than the same
    arithmetic on whole columns. The sum is taken in ``x.sum(axis=1)``'s order.
    """
    a, b, c, d = (x[:, i] for i in range(4))
    total = a + b
    total += c
    total += d
    total -= np.minimum(np.minimum(a, b), np.minimum(c, d))
    total -= np.maximum(np.maximum(a, b), np.maximum(c, d))
    total *= 0.5
    return total


def _median_interval(t: np.ndarray) -> float:
    if t.size < 2:
        return float("nan")
    # 100 000 intervals pin the median; striding keeps it O(1e5) for 10 h logs.
    stride = (t.size - 1) // 100_000 + 1
    m = len(range(0, t.size - 1, stride))
    # Starts 0, s, 2s, ... as strided views; the differences are ours to reorder.
    return _median(t[1::stride][:m] - t[::stride][:m], overwrite_input=True)


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


def _speed_scale_check(speed_wheels: np.ndarray, reference: np.ndarray, radius_m: float) -> None:
    """Compare wheel speeds x nominal radius with a reference speed (GNSS)."""
    moving = np.isfinite(speed_wheels) & np.isfinite(reference) & (reference > 3.0)
    if moving.sum() < 50:
        return
    scale = _median(speed_wheels[moving] / reference[moving])
    if abs(scale - 1.0) <= _SCALE_TOLERANCE:
        return
    raw_over_true = scale / radius_m  # raw wheel value per m/s of true speed
    for unit, factor in (("km/h", _KMH_PER_MPS), ("m/s", 1.0), ("rpm", _RPM_PER_RADPS / radius_m)):
        if abs(raw_over_true / factor - 1.0) < 0.1:
            raise BadInputError(
                f"wheel speeds: expected rad/s, got values that look like {unit} (wheel speed x "
                f"radius {radius_m:g} m is {scale:.3g} x speed_reference)"
            )
    raise BadInputError(
        f"wheel speeds: expected rad/s matching speed_reference with radius {radius_m:g} m, got "
        f"wheel speed x radius = {scale:.3g} x speed_reference"
    )


def _regression_slope(x: np.ndarray, y: np.ndarray) -> tuple[float, float, int]:
    """Slope and correlation of y on x (with intercept) over the finite pairs."""
    ok = np.isfinite(x) & np.isfinite(y)
    n = int(ok.sum())
    if n < 50:
        return float("nan"), float("nan"), n
    xs, ys = x[ok] - x[ok].mean(), y[ok] - y[ok].mean()
    sxx, syy = float(xs @ xs), float(ys @ ys)
    if sxx <= 0 or syy <= 0:
        return float("nan"), float("nan"), n
    sxy = float(xs @ ys)
    return sxy / sxx, sxy / np.sqrt(sxx * syy), n


def _sd_ratio(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """sd(y)/sd(x) and corr(x, y) over the finite pairs (NaN if fewer than 50)."""
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 50:
        return float("nan"), float("nan")
    xs, ys = x[ok] - x[ok].mean(), y[ok] - y[ok].mean()
    sx, sy = float(np.sqrt(xs @ xs)), float(np.sqrt(ys @ ys))
    if sx <= 0 or sy <= 0:
        return float("nan"), float("nan")
    return sy / sx, float(xs @ ys) / (sx * sy)


# A unit mistake changes a scale by >= 1.6 (m/s vs rad/s: 1/R ~ 3; g vs m/s²: 9.8; deg: 57);
# IMU scale, grade and vibration move the sd ratio by < 25 % (real RAV4 log: 0.90-0.96).
_RATIO_BAND = (0.6, 1.6)


def _imu_scale_check(speed_wheels: np.ndarray, ax: np.ndarray, dt_s: float, rate_hz: float) -> None:
    """d(wheel speed x radius)/dt and the IMU ax must have the same scale when both vary."""
    window = window_samples(1.0, rate_hz)
    dv = smoothed_derivative(speed_wheels, dt_s, window)
    ax_s = nan_moving_average(ax, window)
    if not max(float(np.nanstd(ax_s)), float(np.nanstd(dv))) > 0.3:
        return  # too little acceleration to compare scales
    ratio, corr = _sd_ratio(dv, ax_s)
    if not corr > 0.8:
        return
    if ratio > _RATIO_BAND[1]:
        raise BadInputError(
            f"wheel speeds vs ax: expected d(wheel speed x radius)/dt ~ ax, got ax {ratio:.2f} x "
            "larger (wheel speeds in m/s instead of rad/s?)"
        )
    if ratio < _RATIO_BAND[0]:
        raise BadInputError(
            f"wheel speeds vs ax: expected d(wheel speed x radius)/dt ~ ax, got ax {ratio:.3f} x "
            "smaller (ax in g instead of m/s², or wheel speeds in rpm?)"
        )


def _lateral_check(speed: np.ndarray, yaw_rate: np.ndarray, ay: np.ndarray, rate_hz: float) -> None:
    """ay must follow V·ψ̇ with the same scale when both vary."""
    window = window_samples(1.0, rate_hz)
    kin = nan_moving_average(speed * yaw_rate, window)
    ay_s = nan_moving_average(ay, window)
    if not max(float(np.nanstd(kin)), float(np.nanstd(ay_s))) > 0.3:
        return
    ratio, corr = _sd_ratio(kin, ay_s)
    if not abs(corr) > 0.8:
        return
    if not _RATIO_BAND[0] <= ratio <= _RATIO_BAND[1]:
        raise BadInputError(
            f"ay vs speed x yaw_rate: expected the same scale, got ay {ratio:.3g} x speed x "
            "yaw_rate (ay in g, or yaw_rate in deg/s?)"
        )
    if corr < 0:
        # Both follow the same ISO 8855 convention (left positive): a z-down IMU is turned
        # before this check, so a negative correlation is one sign flipped against the other.
        raise BadInputError(
            f"ay vs speed x yaw_rate: expected the same sign (ISO 8855, left positive), got "
            f"correlation {corr:.2f} (IMU mounted backwards, or ay or yaw_rate sign flipped?)"
        )


def _wheel_consistency_check(wheel: np.ndarray, speed_scale: float) -> None:
    """Each wheel within 5 % of the median of four over the moving samples."""
    med = median_of_four(wheel)
    moving = np.isfinite(med) & (med * speed_scale > 3.0)
    if moving.sum() < 50:
        return
    for i, name in enumerate(WHEEL_COLUMNS):
        ok = moving & np.isfinite(wheel[:, i])
        if ok.sum() < 50:
            continue
        ratio = _median(wheel[ok, i] / med[ok])
        # Radius differences and cruising slip stay within ~2 %; 5 % for a whole log is a unit,
        # channel or tyre-size mistake.
        if abs(ratio - 1.0) > 0.05:
            raise BadInputError(
                f"{name}: expected within 5% of the other wheels, got {ratio:.3f} x their median "
                "over the whole log (unit or channel mix-up?)"
            )


def _steering_check(
    steer: np.ndarray,
    yaw_rate: np.ndarray,
    speed: np.ndarray,
    wheelbase_m: float,
    steering_ratio: float,
    rate_hz: float,
) -> None:
    """Yaw rate against the kinematic V δ / L: slope ~0.3-1 in rad, 57x smaller in degrees."""
    window = window_samples(0.5, rate_hz)
    kinematic = nan_moving_average(speed * steer / (steering_ratio * wheelbase_m), window)
    yaw = nan_moving_average(yaw_rate, window)
    moving = speed > 5.0
    kin, yaw = np.where(moving, kinematic, np.nan), np.where(moving, yaw, np.nan)
    if not np.nanstd(yaw) > 0.01:  # below ~0.5 deg/s of yaw: no cornering to compare with
        return
    slope, corr, _ = _regression_slope(kin, yaw)
    if not np.isfinite(corr) or abs(corr) < 0.6:
        return
    if abs(slope) < 0.08:
        raise BadInputError(
            f"steering_wheel_angle: expected rad, got values that look like degrees (yaw rate is "
            f"{slope:.3f} x the kinematic V·δ/L)"
        )
    if abs(slope) > 5.0:
        raise BadInputError(
            f"yaw_rate: expected rad/s, got values that look like deg/s (yaw rate is {slope:.1f} x "
            "the kinematic V·δ/L)"
        )
    if corr < 0:
        raise BadInputError(
            f"yaw_rate vs steering_wheel_angle: expected the same sign convention (ISO 8855, left "
            f"positive), got correlation {corr:.2f}"
        )


def _unit_checks(data: dict[str, np.ndarray], vehicle: Vehicle | None, rate_hz: float) -> None:
    """Plausibility of units by physical consistency between channels.

    The comparisons use 0.5-1 s averages, so they run on a view decimated to about 20 Hz: five
    times less work at 100 Hz and the same answer.
    """
    step = max(1, int(rate_hz // 20))
    rate = rate_hz / step
    view = {name: x[::step] for name, x in data.items()}
    radius = vehicle.wheel_radius_m if vehicle is not None else _DEFAULT_RADIUS_M
    wheelbase = vehicle.wheelbase_m if vehicle is not None else _DEFAULT_WHEELBASE_M
    ratio = vehicle.steering_ratio if vehicle is not None else _DEFAULT_STEERING_RATIO
    wheel = np.array([view[c] for c in WHEEL_COLUMNS]).T  # columns contiguous
    speed = radius * median_of_four(wheel)  # median of four: robust to one spinning wheel
    _wheel_consistency_check(wheel, radius)
    if "speed_reference" in view:
        _speed_scale_check(speed, view["speed_reference"], radius)
    _imu_scale_check(speed, view["ax"], 1.0 / rate, rate)
    check_ax_sign(speed, view["ax"], rate)
    _lateral_check(speed, view["yaw_rate"], view["ay"], rate)
    _steering_check(view["steering_wheel_angle"], view["yaw_rate"], speed, wheelbase, ratio, rate)
    check_lateral_signs(
        view["steering_wheel_angle"], view["yaw_rate"], view["ay"], speed, wheelbase, ratio, rate
    )
    check_steering_scale(
        view["steering_wheel_angle"], view["yaw_rate"], speed, wheelbase, ratio, rate
    )


def validate_stream(
    df: pd.DataFrame,
    vehicle: Vehicle | None = None,
    *,
    min_samples: int = MIN_SAMPLES,
    max_fill_s: float = 0.1,
) -> ValidatedStream:
    """Validate a stream table and resample it onto one uniform time base.

    Parameters
    ----------
    df : pandas.DataFrame
        As returned by :func:`tyrebayes.streams.read_stream`.
    vehicle : Vehicle, optional
        Sharpens the unit plausibility checks (wheel radius, wheelbase, steering ratio); without
        it a mid-size car is assumed (R = 0.32 m, L = 2.7 m, ratio 15).
    min_samples : int
        Fewest rows with all four wheel speeds that the pipeline accepts.
    max_fill_s : float
        Longest gap [s] bridged by linear interpolation; longer gaps stay NaN.

    Returns
    -------
    ValidatedStream

    Raises
    ------
    BadInputError
        With a one-line reason; see the module docstring for the list.
    """
    _check_columns(df)
    cols = _numeric_columns(df)
    t = cols["time"]
    if t.size < min_samples:
        raise BadInputError(f"too few samples: expected at least {min_samples} rows, got {t.size}")
    _check_time(t)
    notes: list[str] = []
    _infinite_as_dropped(cols, notes)
    # Each channel's finite range, found once: the range and the stuck-sensor checks read it.
    bounds = {name: _finite_range(x) for name, x in cols.items() if name != "time"}
    _check_ranges(cols, bounds)
    _check_channels(cols, bounds, notes)
    # Each channel's valid instants and median interval, found once: the wheel counts, the
    # wheel rate, the dropped fractions, the channel rates and the resampling all read them.
    finite = {name: np.isfinite(x) for name, x in cols.items() if name != "time"}
    # Each wheel may come in its own CAN message (own instants in an MDF file): count and time
    # each wheel channel on its own samples.
    wheel_counts = [int(finite[c].sum()) for c in WHEEL_COLUMNS]
    if min(wheel_counts) < min_samples:
        raise BadInputError(
            f"too few samples: expected at least {min_samples} values of each wheel speed, "
            f"got {min(wheel_counts)}"
        )
    valid_time = {name: t if ok.all() else t[ok] for name, ok in finite.items()}
    interval = {name: _median_interval(tv) for name, tv in valid_time.items()}
    wheel_dt = float(np.median([interval[c] for c in WHEEL_COLUMNS]))
    radius = vehicle.wheel_radius_m if vehicle is not None else _DEFAULT_RADIUS_M
    # One wheel: in a file with each wheel on its own instants a median of four has no rows.
    check_time_base(t, radius * cols["wheel_speed_fl"], cols["ax"], wheel_dt)
    _fix_imu_frame(cols, notes)  # sign flips only: the valid instants stay
    dropped = {name: dropped_fraction(valid_time[name]) for name in REQUIRED_COLUMNS[1:]}

    # np.mean(~ok) as a count: the same quotient of two whole numbers.
    nan_fraction = {name: (ok.size - np.count_nonzero(ok)) / ok.size for name, ok in finite.items()}
    channel_rate = {
        name: float(1.0 / dt_c) if dt_c > 0 else float("nan") for name, dt_c in interval.items()
    }
    # Each channel's valid values, picked out once for the quantisation and noise estimates.
    values = {
        name: cols[name] if ok.all() else cols[name][ok]
        for name, ok in finite.items()
        if name in CHANNELS
    }
    quant = {name: quantisation_step(values[name]) for name in REQUIRED_COLUMNS[1:]}
    if "speed_reference" in cols:
        quant["speed_reference"] = quantisation_step(values["speed_reference"])

    noise = {
        name: white_noise_sd(values[name], quant.get(name, 0.0))
        for name in cols
        if name != "time" and name in CHANNELS
    }

    grid, resampled = _time_base(t, wheel_dt)
    dt_s = float(grid[1] - grid[0])
    rate_hz = 1.0 / dt_s
    # One float block, a row per column: the table is a view of it (no consolidating copy).
    names = ["time", *(name for name in cols if name != "time")]
    block = np.empty((len(names), grid.size))
    data: dict[str, np.ndarray] = {}
    filled = np.zeros(grid.shape, dtype=bool)
    shared = _SharedSearch(grid, t) if resampled else None
    for row, name in zip(block, names, strict=True):
        data[name] = row
        x = grid if name == "time" else cols[name]
        if name == "time" or (not resampled and np.all(np.isfinite(x))):
            row[:] = x
            continue
        if shared is None:
            row[:], bridged = _resample_channel(
                grid, t, x, max_fill_s, valid_time=valid_time[name], period=interval[name]
            )
        else:
            bridged = _resample_shared(
                grid, t, x, max_fill_s, shared, interval[name], valid_time[name], out=row
            )
        if name in REQUIRED_COLUMNS and bridged is not None:
            filled |= bridged
    out = pd.DataFrame(block.T, columns=names, copy=False)

    _unit_checks(data, vehicle, rate_hz)
    complete = np.isfinite(data[WHEEL_COLUMNS[0]])
    for name in WHEEL_COLUMNS[1:]:
        complete &= np.isfinite(data[name])
    missing = ~complete
    gaps = _runs(grid, missing)
    flags = sampling_flags(rate_hz, gaps, dropped)
    return ValidatedStream(
        data=out,
        sample_rate_hz=float(rate_hz),
        filled=filled,
        nan_fraction=nan_fraction,
        channel_rate_hz=channel_rate,
        quantisation=quant,
        noise=noise,
        gaps=gaps,
        resampled=resampled,
        notes=tuple(notes),
        flags=tuple(flags),
    )


def _runs(
    time: Float[np.ndarray, "n"], mask: Bool[np.ndarray, "n"]
) -> tuple[tuple[float, float], ...]:
    """(start, end) times of the contiguous True runs of ``mask``."""
    padded = np.concatenate(([False], mask, [False])).astype(np.int8)
    edges = np.diff(padded)
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    return tuple((float(time[s]), float(time[e])) for s, e in zip(starts, ends, strict=True))
