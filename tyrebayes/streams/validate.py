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
from jaxtyping import Bool

from .._errors import BadInputError
from ..physics.vehicle import Vehicle
from .noise import quantisation_step, white_noise_sd
from .order_stats import median_of_four as median_of_four
from .order_stats import nanmedian
from .plausibility import check_time_base, dropped_fraction, sampling_flags
from .resample import (
    _median_interval,
    _resample_channel,
    _resample_shared,
    _runs,
    _SharedSearch,
    _time_base,
)
from .schema import CHANNELS, MIN_SAMPLES, OPTIONAL_COLUMNS, REQUIRED_COLUMNS, WHEEL_COLUMNS
from .unit_checks import _DEFAULT_RADIUS_M, _unit_checks


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

    Examples
    --------
    >>> from tyrebayes import load_vehicle, read_stream
    >>> from tyrebayes._resources import data_dir
    >>> df = read_stream(data_dir() / "comma2k19_rav4_segment.csv")
    >>> stream = validate_stream(df, load_vehicle("suv_rav4"))
    >>> round(stream.sample_rate_hz, 1), stream.resampled, stream.flags
    (89.2, True, ())
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

    Examples
    --------
    >>> from tyrebayes import load_vehicle, read_stream
    >>> from tyrebayes._resources import data_dir
    >>> df = read_stream(data_dir() / "comma2k19_rav4_segment.csv")
    >>> stream = validate_stream(df, load_vehicle("suv_rav4"))
    >>> len(df), len(stream.data), round(stream.sample_rate_hz, 1)
    (4974, 5352, 89.2)
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

    nan_fraction, channel_rate, quant, noise = _channel_statistics(cols, finite, interval)
    grid, resampled = _time_base(t, wheel_dt)
    dt_s = float(grid[1] - grid[0])
    rate_hz = 1.0 / dt_s
    out, data, filled = _resample_table(
        grid, t, cols, resampled, max_fill_s, valid_time=valid_time, interval=interval
    )

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


def _channel_statistics(
    cols: dict[str, np.ndarray], finite: dict[str, np.ndarray], interval: dict[str, float]
) -> tuple[dict[str, float], dict[str, float], dict[str, float], dict[str, float]]:
    """Each channel's NaN fraction, rate, quantisation step and white-noise sd, on its own samples.

    Returns ``(nan_fraction, channel_rate_hz, quantisation, noise)``, the
    :class:`ValidatedStream` fields of those names.
    """
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
    return nan_fraction, channel_rate, quant, noise


def _resample_table(
    grid: np.ndarray,
    t: np.ndarray,
    cols: dict[str, np.ndarray],
    resampled: bool,
    max_fill_s: float,
    *,
    valid_time: dict[str, np.ndarray],
    interval: dict[str, float],
) -> tuple[pd.DataFrame, dict[str, np.ndarray], np.ndarray]:
    """Every column on ``grid``: the table, its columns by name, and the bridged samples."""
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
    return pd.DataFrame(block.T, columns=names, copy=False), data, filled
