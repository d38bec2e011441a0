"""Step 1 of the signal pipeline: smoothed channels, each wheel's speed as V_x, the vehicle
speed and slips (thesis chapter 4.3, eqs. 2.1 and 4.23).

The steps' scales (:class:`_Scales`) live here too: every later step reads them. Called by
:func:`tyrebayes.streams.features.compute_features`.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np
from jaxtyping import Bool, Float

from ..physics.vehicle import GRAVITY_MPS2, Vehicle
from .filters import PrefixSums, nan_moving_average, window_samples
from .order_stats import median_of_four
from .schema import WHEEL_COLUMNS

_NON_DRIVEN = {"fwd": (2, 3), "rwd": (0, 1), "awd": (0, 1, 2, 3)}


def _columns(*columns: np.ndarray) -> np.ndarray:
    """Columns side by side as an (n, k) array whose columns are contiguous (Fortran order).

    The pipeline works on whole columns (one wheel, one axle); in NumPy a reduction across a
    C-ordered row of four costs about ten column operations, and a moving average down a
    column of a C-ordered table a quarter more than down a contiguous one.
    """
    out = np.empty((len(columns), columns[0].shape[0]))
    for row, column in zip(out, columns, strict=True):
        row[:] = column
    return out.T


def _table(n: int, k: int) -> np.ndarray:
    """An empty (n, k) array with contiguous columns, for results written column by column."""
    return np.empty((k, n)).T


def _row_mean(x: np.ndarray, columns: tuple[int, ...], out: np.ndarray | None = None) -> np.ndarray:
    """``x[:, columns].mean(axis=1)`` column by column, summed in NumPy's order."""
    total = np.empty(x.shape[0]) if out is None else out
    np.copyto(total, x[:, columns[0]])
    for i in columns[1:]:
        total += x[:, i]
    total /= len(columns)
    return total


def _wheel_to_vx(
    wheel_radps: np.ndarray,
    yaw: np.ndarray,
    vehicle: Vehicle,
    trig: tuple[np.ndarray, np.ndarray],
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Each wheel's longitudinal speed translated to the CoG V_x.

    A wheel at (x_i, y_i) moves with (V_x − ψ̇ y_i, V_y + ψ̇ x_i); the front wheels point along δ,
    so the front wheels' speed u_i = R Ω_i = V_x cos δ + (V_y + ψ̇ l_f) sin δ, with the front
    axle's lateral speed V_y + ψ̇ l_f = ψ̇ L − α_r V_x of :func:`_front_terms`. Solved for V_x:
    V_x = (u_i − ψ̇ L sin δ)/(cos δ − α_r sin δ) + ψ̇ y_i; the rear wheels need only the ψ̇ y_i
    term. ``trig`` is (1/(cos δ − α_r sin δ), ψ̇ L sin δ), computed once for several calls; the
    output is written in place, column by column (no temporaries of shape (n, 4)).
    """
    inv_cos, yaw_l_sin = trig
    yaw_half = yaw * (0.5 * vehicle.track_width_m)
    if out is None:
        out = np.empty(wheel_radps.shape[::-1]).T  # columns contiguous
    radius = vehicle.wheel_radius_m
    for i, sign in enumerate((1.0, -1.0, 1.0, -1.0)):
        col = out[:, i]
        np.multiply(wheel_radps[:, i], radius, out=col)
        if i < 2:
            col -= yaw_l_sin
            col *= inv_cos
        if sign > 0:
            col += yaw_half
        else:
            col -= yaw_half
    return out


# Cornering stiffness of the rear axle per unit of its load [1/rad]: radial passenger tyres have
# a cornering coefficient of about 0.2 per degree (Gillespie 1992, Fundamentals of Vehicle
# Dynamics, ch. 6), 11.5 per radian. It sets only the rear slip angle's share of the front
# axle's lateral speed, α_r sin δ, a few 1e-4 of slip where δ is large; an error of half of it
# moves a window's slip by less than its noise.
REAR_CORNERING_PER_RAD = 11.5


def _front_terms(
    yaw: np.ndarray, steer: np.ndarray, ay: np.ndarray, vehicle: Vehicle
) -> tuple[np.ndarray, np.ndarray]:
    """(1/(cos δ − α_r sin δ), ψ̇ L sin δ) of :func:`_wheel_to_vx`.

    The front axle's lateral speed from the single-track model in a steady turn: the rear axle
    moves sideways at −α_r V_x, with α_r = F_yr/C_r = a_y/(g c_r) (the rear axle carries
    m a_y l_f/L, its static load times a_y/g; c_r = :data:`REAR_CORNERING_PER_RAD`), so
    V_y + ψ̇ l_f = ψ̇ L − α_r V_x. With β = 0 (thesis eq. 4.23) the term ψ̇ l_r sin δ/V_x is
    left out: in a turn of radius R at walking pace it is l_r L/R², 1.9 % of slip at R = 15 m
    (l_r 1.64 m, L 2.65 m), where the slip a wheel transmits is a few per mille.
    """
    sin, cos = np.sin(steer), np.cos(steer)
    rear_slip_angle = ay / (GRAVITY_MPS2 * REAR_CORNERING_PER_RAD)
    # In place: 1/(cos − α_r sin) in the cosine's array, ψ̇ L sin in the sine's.
    rear_slip_angle *= sin
    cos -= rear_slip_angle
    np.divide(1.0, cos, out=cos)
    sin *= yaw * vehicle.wheelbase_m
    return cos, sin


def _vehicle_speed(
    wheel_vx: np.ndarray, drive: str, spin_threshold: float
) -> tuple[np.ndarray, np.ndarray]:
    """V_x from the non-driven wheels and the spin/lock flag (thesis 4.3.2)."""
    if drive == "awd":
        # No free wheel: the median of four is robust to one spinning or locking wheel; slip is
        # then measured relative to the other driven wheels (biased towards zero).
        median = median_of_four(wheel_vx)
        return median, np.zeros(wheel_vx.shape[0], dtype=bool)
    a, b = _NON_DRIVEN[drive]
    va, vb = wheel_vx[:, a], wheel_vx[:, b]
    mean = np.add(va, vb)
    mean *= 0.5
    difference = np.subtract(va, vb)
    np.abs(difference, out=difference)
    limit = np.abs(mean)
    limit *= spin_threshold
    with np.errstate(invalid="ignore", divide="ignore"):
        disagree = difference > limit
    # A non-driven wheel cannot spin up, only lock under braking: the faster one is closer to V.
    np.maximum(va, vb, out=limit)
    np.copyto(mean, limit, where=disagree)
    return mean, disagree


def _spin_check(wheel_vx: np.ndarray, vx: np.ndarray, drive: str, threshold: float) -> np.ndarray:
    """Driven vs non-driven wheel on the same side differing by more than ``threshold``."""
    if drive == "awd":
        pairs = ((0, 2), (1, 3))
    else:
        d = (0, 1) if drive == "fwd" else (2, 3)
        nd = _NON_DRIVEN[drive]
        pairs = ((d[0], nd[0]), (d[1], nd[1]))
    left, right = (np.subtract(wheel_vx[:, i], wheel_vx[:, j]) for i, j in pairs)
    np.abs(left, out=left)
    np.abs(right, out=right)
    np.maximum(left, right, out=left)
    limit = np.abs(vx)
    limit *= threshold
    with np.errstate(invalid="ignore"):
        return (left > limit) & np.isfinite(vx)


class _Scales(eqx.Module):
    """The pipeline's sample counts at the stream's rate: smoothing, derivative, noise span."""

    rate_hz: float
    dt_s: float
    window: int  # smoothing window [samples]
    deriv_window: int  # window of the speed and yaw-rate derivatives (≥ 0.5 s) [samples]
    span: int  # span of the local noise estimates (10 s) [samples]
    smoothing_s: float

    @classmethod
    def of(cls, rate_hz: float, smoothing_s: float) -> _Scales:
        return cls(
            rate_hz=float(rate_hz),
            dt_s=1.0 / rate_hz,
            window=window_samples(smoothing_s, rate_hz),
            deriv_window=window_samples(max(smoothing_s, 0.5), rate_hz),
            span=window_samples(10.0, rate_hz),
            smoothing_s=float(smoothing_s),
        )


class _Motion(eqx.Module):
    """Step 1: smoothed channels, each wheel's speed as V_x, the vehicle speed and slips."""

    omega_raw: Float[np.ndarray, "n 4"]  # unsmoothed wheel speeds [rad/s]
    gap: Bool[np.ndarray, "n"]  # a wheel speed missing
    yaw: Float[np.ndarray, "n"]  # smoothed yaw rate [rad/s]
    steer: Float[np.ndarray, "n"]  # front road-wheel angle [rad]
    ax_raw: Float[np.ndarray, "n"]  # smoothed IMU ax, uncorrected [m/s²]
    # Prefix sums of the raw IMU ax and of V_x: later steps smooth them over other windows.
    ax_prefix: PrefixSums
    vx_prefix: PrefixSums
    ay_raw: Float[np.ndarray, "n"]  # smoothed IMU ay, uncorrected [m/s²]
    trig: tuple  # the front wheels' geometry terms (_front_terms)
    wheel_vx: Float[np.ndarray, "n 4"]  # [m/s]
    vx: Float[np.ndarray, "n"]  # [m/s]
    spin: Bool[np.ndarray, "n"]
    valid: Bool[np.ndarray, "n"]
    vx_safe: Float[np.ndarray, "n"]  # V_x, NaN where not valid [m/s]
    slip: Float[np.ndarray, "n 4"]
    slip_axle: Float[np.ndarray, "n 2"]
    slip_driven: Float[np.ndarray, "n"]
    driven_wheels: tuple[int, ...] = eqx.field(static=True)


def _motion(stream, vehicle, scales, spin_threshold, thresholds) -> _Motion:
    data = stream.data
    # Channels resampled onto one grid mostly share their gaps: each channel's prefix sums
    # reuse the previous one's counts where the NaN agree.
    last: list[PrefixSums | None] = [None]

    def prefix(name: str) -> PrefixSums:
        last[0] = PrefixSums.of(data[name].to_numpy(dtype=float), like=last[0])
        return last[0]

    def smooth(name: str) -> np.ndarray:
        return prefix(name).window_mean(scales.window // 2)

    omega_raw = _columns(*(data[c].to_numpy(dtype=float) for c in WHEEL_COLUMNS))
    gap = ~np.all(np.isfinite(omega_raw), axis=1)
    omega = nan_moving_average(omega_raw, scales.window)
    yaw = smooth("yaw_rate")
    if "wheel_angle_front" in data:
        steer = smooth("wheel_angle_front")
    else:
        steer = smooth("steering_wheel_angle") / vehicle.steering_ratio
    ax_prefix = prefix("ax")
    ax_raw, ay_raw = ax_prefix.window_mean(scales.window // 2), smooth("ay")

    trig = _front_terms(yaw, steer, ay_raw, vehicle)
    wheel_vx = _wheel_to_vx(omega, yaw, vehicle, trig)
    vx, lock = _vehicle_speed(wheel_vx, vehicle.drive, spin_threshold)
    spin = _spin_check(wheel_vx, vx, vehicle.drive, spin_threshold) | lock
    valid = ~gap & np.isfinite(vx) & (vx > thresholds.min_speed_mps)
    vx_safe = np.where(valid, vx, np.nan)

    slip = _table(vx.shape[0], 4)
    for i in range(4):
        np.subtract(wheel_vx[:, i], vx_safe, out=slip[:, i])
        slip[:, i] /= vx_safe
    slip_axle = _table(vx.shape[0], 2)
    _row_mean(slip, (0, 1), out=slip_axle[:, 0])
    _row_mean(slip, (2, 3), out=slip_axle[:, 1])
    driven_wheels = {"front": (0, 1), "rear": (2, 3), "both": (0, 1, 2, 3)}[vehicle.driven_axle]
    slip_driven = _row_mean(slip, driven_wheels)
    return _Motion(
        omega_raw=omega_raw,
        gap=gap,
        yaw=yaw,
        steer=steer,
        ax_raw=ax_raw,
        ax_prefix=ax_prefix,
        vx_prefix=PrefixSums.of(vx_safe),
        ay_raw=ay_raw,
        trig=trig,
        wheel_vx=wheel_vx,
        vx=vx,
        spin=spin,
        valid=valid,
        vx_safe=vx_safe,
        slip=slip,
        slip_axle=slip_axle,
        slip_driven=slip_driven,
        driven_wheels=driven_wheels,
    )
