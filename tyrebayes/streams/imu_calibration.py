"""Step 3 of the signal pipeline: the IMU's gain and offsets against the wheel speeds, the
corrected a_x (road grade kept), a_y and the grade.

Called by :func:`tyrebayes.streams.features.compute_features`.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np
from jaxtyping import Float

from ..physics.vehicle import GRAVITY_MPS2, body_pitch_gain
from .filters import smoothed_derivative
from .motion import _Motion, _Scales
from .nuisances import (
    ImuGainCorrection,
    estimate_ax_gain,
    estimate_ax_offset,
    imu_gain_correction,
    mean_grade_sd,
)
from .order_stats import median


class _ImuCalibration(eqx.Module):
    """Step 3: the IMU's gain and offsets against the wheel speeds; corrected ax, ay, grade."""

    pitch_gain: float  # squat/dive over-read 1 + g·k [-]
    dvx_dt: Float[np.ndarray, "n"]  # [m/s²]
    imu_gain: ImuGainCorrection
    ax_offset: float  # [m/s²]
    ax_offset_sd: float  # [m/s²]
    ax: Float[np.ndarray, "n"]  # corrected, grade included [m/s²]
    grade: Float[np.ndarray, "n"]  # [rad]
    ay_offset: float  # [m/s²]
    ay: Float[np.ndarray, "n"]  # [m/s²]
    lateral_kin: Float[np.ndarray, "n"]  # V_x · yaw rate [m/s²]
    yaw_acc: Float[np.ndarray, "n"]  # [rad/s²]


def _imu_calibration(
    stream, vehicle, motion: _Motion, scales: _Scales, ax_offset_mps2, ax_gain
) -> _ImuCalibration:
    m, rate = motion, scales.rate_hz
    # IMU offset against the wheel-speed derivative; the corrected ax keeps the road grade.
    # Squat and dive add g·k·a_x to the reading: left in, the forces read 1 + g·k ≈ 2 % high and
    # C_x with them (the model's force gain is centred at 1), and a drive that brakes more than
    # it accelerates would shift the offset.
    pitch_gain = float(body_pitch_gain(vehicle))
    dvx_dt = m.vx_prefix.smoothed_derivative(scales.deriv_window // 2, scales.dt_s)
    ax_smooth_d = m.ax_prefix.window_mean(scales.deriv_window // 2)
    steady = m.valid & ~m.spin & (np.abs(dvx_dt) < 4.0)
    # The IMU's scale factor against the wheel speeds' dV_x/dt (which the pitch over-read is part
    # of): a calibrated IMU is left to the tyre model's force gain, a badly scaled one (a
    # dashcam) would scale every force and C_x with it, so ax is divided by its estimate.
    if ax_gain is None:
        gain, gain_sd = estimate_ax_gain(ax_smooth_d, dvx_dt, steady, rate)
        imu_gain = imu_gain_correction(gain / pitch_gain, gain_sd / pitch_gain)
    else:
        # Given, not estimated: certain, and uncalibrated exactly when it is not 1.
        imu_gain = ImuGainCorrection(
            float(ax_gain), 0.0, float(ax_gain != 1.0), float(ax_gain), 0.0
        )
    ax_raw = m.ax_raw / imu_gain.applied
    ax_smooth_d = ax_smooth_d / imu_gain.applied - (pitch_gain - 1.0) * dvx_dt
    if ax_offset_mps2 is None:
        ax_offset, ax_offset_sd = estimate_ax_offset(ax_smooth_d, dvx_dt, steady, rate)
        if not np.isfinite(ax_offset):
            ax_offset, ax_offset_sd = 0.0, float("nan")
    else:
        ax_offset, ax_offset_sd = float(ax_offset_mps2), 0.0
    ax = (ax_raw - ax_offset) / pitch_gain
    grade = np.arcsin(np.clip((ax_smooth_d - ax_offset - dvx_dt) / GRAVITY_MPS2, -1.0, 1.0))
    if ax_offset_mps2 is None:
        # The offset also holds g·sin(mean grade of this log), which nothing in one log can
        # separate from the mounting pitch: widen its error by the mean grade's uncertainty.
        grade_mean_sd = mean_grade_sd(grade[steady], rate)
        ax_offset_sd = float(np.hypot(ax_offset_sd, GRAVITY_MPS2 * grade_mean_sd))
    lateral_kin = m.vx_safe * m.yaw
    ay_resid = (m.ay_raw - lateral_kin)[m.valid & np.isfinite(m.ay_raw)]
    ay_offset = median(ay_resid) if ay_resid.size else 0.0
    return _ImuCalibration(
        pitch_gain=pitch_gain,
        dvx_dt=dvx_dt,
        imu_gain=imu_gain,
        ax_offset=float(ax_offset),
        ax_offset_sd=float(ax_offset_sd),
        ax=ax,
        grade=grade,
        ay_offset=ay_offset,
        ay=m.ay_raw - ay_offset,
        lateral_kin=lateral_kin,
        yaw_acc=smoothed_derivative(m.yaw, scales.dt_s, scales.deriv_window),
    )
