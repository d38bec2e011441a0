"""Physical plausibility of a stream: each channel checked against the others' kinematics.

Range checks (:mod:`tyrebayes.streams.schema`) catch a unit mistake only when it pushes values
outside what a car can do. The mistakes here stay inside the ranges and still give a wrong answer
with a clean exit: an IMU mounted backwards (``ax`` with the wrong sign), time stamps in
milliseconds, a steering-wheel angle in degrees on a straight drive. The stream's redundancy tells
them apart: the wheel speeds' dV_x/dt against ``ax``, the wheel-speed changes per sample against
the time step, the steering-implied yaw rate V·δ/(i·L) against the gyro. Each contradiction is a
:class:`~tyrebayes.BadInputError` with one line naming the channel, the evidence and the likely
cause.

What is a judgement rather than a mistake (a low sample rate, a long gap, many dropped samples)
becomes a *flag*: one line kept in :attr:`ValidatedStream.flags
<tyrebayes.streams.validate.ValidatedStream.flags>` that ``inspect`` prints, saying why an answer
from this stream may be less certain than it looks.

Examples
--------
>>> import numpy as np
>>> sampling_flags(10.0, gaps=((5.0, 65.0),), dropped={"ax": 0.0})[0][:25]
'sample rate 10 Hz: expect'
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Float

from .._errors import BadInputError
from .filters import nan_moving_average, smoothed_derivative, window_samples
from .log_sample import sample_runs
from .order_stats import median, median_at_most, quantile

#: Below this rate the 0.2 s smoothing of the features holds fewer than 4 samples: the derivatives
#: and the slip noise estimate (measured at the smoothing scale) stop meaning what they say.
MIN_RATE_HZ = 20.0
#: A gap this long breaks the continuity the nuisance and thermal estimates assume (the tyre
#: cools, the IMU offset drifts, the car may have been parked or refuelled).
LONG_GAP_S = 10.0
#: More than this fraction of a required channel lost (interpolated over or missing): the noise
#: estimates see interpolated, smoother-than-measured data and the posterior comes out too narrow.
DROPPED_FLAG_FRACTION = 0.2
#: Longest plausible single drive logged below 1 Hz [s]; a longer one is read as time in ms.
MAX_SLOW_DRIVE_S = 10 * 3600.0

# Correlation of ax with dV_x/dt on the real RAV4 log: +0.88 (0.5 s smoothing, moving samples).
# Grade and vibration lower it, never turn it below zero; -0.5 is a sign error, not noise.
_SIGN_CORRELATION = -0.5
# dV_x/dt must vary by this much [m/s²] for its correlation with ax to mean anything: IMU noise
# after 0.5 s smoothing is ~0.03 m/s²; 0.15 is gentle but real speed change.
_MIN_ACCEL_SD = 0.15
# Gyro noise after 0.5 s smoothing is ~1e-3 rad/s, the lateral accelerometer's ~0.03 m/s²: the
# lateral sign comparisons need their channels to vary by more (the real RAV4 highway minute:
# yaw rate sd 0.0036 rad/s, V·yaw rate 0.06 m/s², ay 0.08 m/s²).
_MIN_YAW_SD = 0.002
_MIN_AY_SD = 0.04
# Steering-implied over measured yaw rate: ~1-2 in rad (understeer, offsets, noise lower the
# measured side), 57x that in degrees. 15 leaves a factor 4 to each side.
_STEER_DEGREES_RATIO = 15.0


def check_time_base(
    time_s: Float[np.ndarray, "n"],
    speed_mps: Float[np.ndarray, "n"],
    ax_mps2: Float[np.ndarray, "n"],
    wheel_dt_s: float,
) -> None:
    """Reject time stamps in milliseconds read as seconds.

    At a true wheel-speed interval ``dt`` the speed changes per sample by about a·dt; time in ms
    read as s makes ``dt`` 1000x too long while the changes stay those of 10 ms. The check runs
    only when the wheel speeds come slower than 1 Hz, which no usable log does.

    Parameters
    ----------
    time_s : ndarray, shape (n,)
        File time stamps as read [s?].
    speed_mps : ndarray, shape (n,)
        Wheel speed x nominal radius (median of four) on the same rows; NaN where missing.
    ax_mps2 : ndarray, shape (n,)
        Longitudinal IMU acceleration on the same rows; NaN where missing.
    wheel_dt_s : float
        Median interval of the wheel-speed samples [s].

    Raises
    ------
    BadInputError
        "time looks like milliseconds", with the evidence.
    """
    if not wheel_dt_s >= 1.0:
        return
    duration = float(time_s[-1] - time_s[0])
    rate = 1.0 / wheel_dt_s
    if duration > MAX_SLOW_DRIVE_S:
        raise BadInputError(
            f"time: expected seconds, got a {duration / 3600:.1f} h drive at {rate:.3g} Hz "
            f"(time looks like milliseconds: {duration / 1000:.1f} s at {1000 * rate:.3g} Hz)"
        )
    ok = np.isfinite(speed_mps)
    t, v = time_s[ok], speed_mps[ok]
    a = ax_mps2[np.isfinite(ax_mps2)]
    if v.size < 20 or a.size < 20 or np.ptp(v) < 1.0:
        return  # a parked car: no speed change to compare the time step with
    implied = np.sqrt(np.mean((np.diff(v) / np.diff(t)) ** 2))  # rms dV/dt by the time stamps
    measured = float(np.std(a))
    # Real data at any rate: implied ~ measured (both are the car's acceleration, ratio ~0.5-2;
    # at cruise the IMU noise keeps ``measured`` up, not down). Time in ms: implied ~ 1e-3 x.
    if implied < 0.05 * measured:
        raise BadInputError(
            f"time: expected seconds, got a {rate:.3g} Hz log whose wheel speeds change by only "
            f"{implied:.2g} m/s² per time step while ax varies by {measured:.2g} m/s² (time looks "
            f"like milliseconds: {duration / 1000:.1f} s at {1000 * rate:.3g} Hz)"
        )


def check_ax_sign(
    speed_mps: Float[np.ndarray, "n"], ax_mps2: Float[np.ndarray, "n"], rate_hz: float
) -> None:
    """``ax`` must rise and fall with the wheel speeds' dV_x/dt (both smoothed over 0.5 s).

    Parameters
    ----------
    speed_mps : ndarray, shape (n,)
        Wheel speed x nominal radius on a uniform time base [m/s].
    ax_mps2 : ndarray, shape (n,)
        Longitudinal IMU acceleration on the same base [m/s²].
    rate_hz : float
        Rate of the time base [Hz].

    Raises
    ------
    BadInputError
        When the correlation is strongly negative: an IMU mounted backwards or a sign flipped in
        the logger.
    """
    window = window_samples(0.5, rate_hz)
    dv = smoothed_derivative(speed_mps, 1.0 / rate_hz, window)
    ax = nan_moving_average(ax_mps2, window)
    ok = np.isfinite(dv) & np.isfinite(ax) & (speed_mps > 3.0)
    if ok.sum() < 50 or not np.std(dv[ok]) > _MIN_ACCEL_SD or not np.std(ax[ok]) > 0:
        return
    corr = float(np.corrcoef(dv[ok], ax[ok])[0, 1])
    if corr < _SIGN_CORRELATION:
        raise BadInputError(
            f"ax: expected the sign of the wheel speeds' dV_x/dt (ISO 8855, forward positive), "
            f"got correlation {corr:.2f} with it (IMU mounted backwards or ax sign flipped?)"
        )


def check_steering_scale(
    steer_rad: Float[np.ndarray, "n"],
    yaw_rate: Float[np.ndarray, "n"],
    speed_mps: Float[np.ndarray, "n"],
    wheelbase_m: float,
    steering_ratio: float,
    rate_hz: float,
) -> None:
    """Steering-wheel angle in degrees on a drive too straight for a correlation to show it.

    Compares magnitudes instead: the 95th percentile of the steering-implied yaw rate
    V·(δ − median δ)/(i·L) against that of the measured one, over samples above 5 m/s. A steering
    offset or sensor noise in rad moves the ratio by a few; degrees multiply it by 57.

    Raises
    ------
    BadInputError
        When the steering implies a yaw rate more than 15x the measured one.
    """
    window = window_samples(0.5, rate_hz)
    steer = nan_moving_average(steer_rad, window)
    yaw = nan_moving_average(yaw_rate, window)
    ok = np.isfinite(steer) & np.isfinite(yaw) & np.isfinite(speed_mps) & (speed_mps > 5.0)
    if ok.sum() < 50:
        return
    kinematic = speed_mps[ok] * (steer[ok] - median(steer[ok])) / (steering_ratio * wheelbase_m)
    implied = quantile(np.abs(kinematic), 0.95)
    # Gyro noise after smoothing is ~1e-3 rad/s: a floor so that a dead-straight drive with a
    # noiseless yaw channel cannot make any steering look large.
    measured = max(quantile(np.abs(yaw[ok] - median(yaw[ok])), 0.95), 1e-3)
    ratio = implied / measured
    if ratio > _STEER_DEGREES_RATIO:
        p99 = float(np.quantile(np.abs(steer_rad[np.isfinite(steer_rad)]), 0.99))
        raise BadInputError(
            f"steering_wheel_angle: expected rad, got values that look like degrees (99th "
            f"percentile {p99:.3g}; it implies {ratio:.0f} x the measured yaw rate through V·δ/L)"
        )


def _correlation(x: np.ndarray, y: np.ndarray, min_sd: float) -> float:
    """Pearson correlation over the finite pairs; NaN with < 50 of them or a flat side."""
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 50:
        return float("nan")
    x, y = x[ok], y[ok]
    if not (np.std(x) > min_sd and np.std(y) > min_sd):
        return float("nan")
    return float(np.corrcoef(x, y)[0, 1])


def check_lateral_signs(
    steer_rad: Float[np.ndarray, "n"],
    yaw_rate: Float[np.ndarray, "n"],
    ay_mps2: Float[np.ndarray, "n"],
    speed_mps: Float[np.ndarray, "n"],
    wheelbase_m: float,
    steering_ratio: float,
    rate_hz: float,
) -> None:
    """Name the one lateral channel whose sign is flipped, from two comparisons that share it.

    The yaw rate is compared with the steering's kinematic V·δ/(i·L) and with ay / V (as V·ψ̇
    with ay), over 0.5 s averages above 5 m/s. Each comparison alone cannot say which of its two
    channels is flipped, and on a straight highway drive neither varies enough for the scale
    checks (real RAV4 log: yaw rate sd 0.004 rad/s, ay sd 0.08 m/s²), but the signs still show
    clearly (correlations +0.90 and +0.83 there). When both comparisons are strong, the channel
    they disagree on is named: both negative, yaw_rate; only the steering one, the steering angle
    (or yaw_rate and ay together: a z-down IMU logged without az, which the reason says); only
    the ay one, ay. A comparison weaker than ±0.5 or too flat decides nothing.

    Raises
    ------
    BadInputError
        Naming ``yaw_rate``, ``steering_wheel_angle`` or ``ay``, with both correlations.
    """
    window = window_samples(0.5, rate_hz)
    moving = np.isfinite(speed_mps) & (speed_mps > 5.0)
    speed = np.where(moving, speed_mps, np.nan)
    kinematic = nan_moving_average(speed * steer_rad / (steering_ratio * wheelbase_m), window)
    yaw = nan_moving_average(np.where(moving, yaw_rate, np.nan), window)
    centripetal = nan_moving_average(speed * yaw_rate, window)
    ay = nan_moving_average(np.where(moving, ay_mps2, np.nan), window)
    c_steer = _correlation(kinematic, yaw, _MIN_YAW_SD)
    c_ay = _correlation(centripetal, ay, _MIN_AY_SD)
    strong = abs(c_steer) > -_SIGN_CORRELATION and abs(c_ay) > -_SIGN_CORRELATION
    if not strong or (c_steer > 0 and c_ay > 0):
        return
    evidence = (
        f"correlation {c_steer:.2f} with the steering's V·δ/(i·L) and {c_ay:.2f} of ay with "
        "V·yaw_rate"
    )
    if c_steer < 0 and c_ay < 0:
        raise BadInputError(
            f"yaw_rate: expected left positive (ISO 8855) like steering_wheel_angle and ay, got "
            f"{evidence} (yaw_rate sign flipped?)"
        )
    if c_steer < 0:
        raise BadInputError(
            f"steering_wheel_angle: expected left positive (ISO 8855) like yaw_rate and ay, got "
            f"{evidence} (steering angle sign flipped, or yaw_rate and ay both, as a z-down IMU "
            "gives them?)"
        )
    raise BadInputError(
        f"ay: expected left positive (ISO 8855) like yaw_rate and steering_wheel_angle, got "
        f"{evidence} (ay sign flipped?)"
    )


def dropped_fraction(time_s: Float[np.ndarray, "m"]) -> float:
    """Fraction of a channel's samples lost between its first and last valid one.

    The channel's own period is the median of its short intervals (those within 1.5x the lower
    quartile), which stays the native period when up to ~70 % of the samples are dropped at
    random, on jittery CAN timing and on channels slower than the table (multi-rate files merged
    by time). Intervals of :data:`LONG_GAP_S` or more are gaps, flagged on their own.

    Parameters
    ----------
    time_s : ndarray, shape (m,)
        Time stamps of the channel's valid samples [s], increasing.

    Returns
    -------
    float
        In [0, 1); 0.0 for fewer than 3 samples.
    """
    if time_s.size < 3:
        return 0.0
    steps = np.diff(time_s)
    short = steps < LONG_GAP_S
    count = int(np.count_nonzero(short))
    # Without long gaps (the usual case) the short steps are all of them: no copy to sum.
    span = float(steps.sum() if count == steps.size else steps[short].sum())
    # The order statistics reorder their input in place: ``steps`` (summed above, in their own
    # order) or a copy of runs of it (:mod:`.log_sample`).
    sample = sample_runs(steps).ravel()
    period = median_at_most(sample, 1.5 * quantile(sample, 0.25, overwrite_input=True), True)
    if not (period > 0 and span > 0):
        return 0.0
    return max(0.0, 1.0 - count * period / span)


def sampling_flags(
    rate_hz: float,
    gaps: tuple[tuple[float, float], ...],
    dropped: dict[str, float],
) -> list[str]:
    """Flags on sampling that make an answer less certain than it looks (not errors).

    Parameters
    ----------
    rate_hz : float
        Rate of the uniform time base [Hz].
    gaps : tuple of (float, float)
        Intervals [s] without wheel speeds.
    dropped : dict
        Per required channel, the fraction of the time base where it was interpolated over a
        dropped sample or is missing.

    Returns
    -------
    list of str
        One line per flag.
    """
    flags = []
    if rate_hz < MIN_RATE_HZ:
        samples = window_samples(0.2, rate_hz)
        flags.append(
            f"sample rate {rate_hz:.3g} Hz: expected >= {MIN_RATE_HZ:g} Hz; slip windows of "
            f"0.2-0.25 s hold {samples} sample{'s' if samples > 1 else ''}, too few for the noise "
            "estimates and derivatives (C_x may be biased)"
        )
    long = [(a, b) for a, b in gaps if b - a >= LONG_GAP_S]
    if long:
        a, b = max(long, key=lambda g: g[1] - g[0])
        flags.append(
            f"{len(long)} gap{'s' if len(long) > 1 else ''} of >= {LONG_GAP_S:g} s without wheel "
            f"speeds (longest {b - a:.1f} s at {a:.1f} s): the drive is treated as one, though "
            "tyre temperature and sensor offsets may have changed across it"
        )
    worst = max(dropped, key=dropped.get, default=None)
    if worst is not None and dropped[worst] > DROPPED_FLAG_FRACTION:
        flags.append(
            f"{worst}: {100 * dropped[worst]:.0f}% of the samples dropped (interpolated or "
            "missing): noise estimates see smoothed data and intervals may be too narrow"
        )
    return flags
