"""Unit mistakes found by physical consistency between channels that stay inside every range.

Wheel speeds against each other and against the reference speed, d(wheel speed x radius)/dt
against the IMU's a_x, a_y against V·ψ̇, the yaw rate against the steering's V·δ/L; the
sign checks that name one flipped channel are :mod:`tyrebayes.streams.plausibility`'s, called
from :func:`_unit_checks` too. Called by :func:`tyrebayes.streams.validate.validate_stream`.
"""

from __future__ import annotations

import numpy as np

from .._errors import BadInputError
from ..physics.vehicle import Vehicle
from .filters import nan_moving_average, smoothed_derivative, window_samples
from .order_stats import median as _median
from .order_stats import median_of_four
from .plausibility import check_ax_sign, check_lateral_signs, check_steering_scale
from .schema import WHEEL_COLUMNS

# Defaults when no vehicle is given: a mid-size car.
_DEFAULT_RADIUS_M = 0.32


_DEFAULT_WHEELBASE_M = 2.7


_DEFAULT_STEERING_RATIO = 15.0


_KMH_PER_MPS = 3.6


_RPM_PER_RADPS = 60.0 / (2.0 * np.pi)


# Wheel radius vs GNSS: tyre size, wear and pressure change the rolling radius by a few percent.
_SCALE_TOLERANCE = 0.07


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
