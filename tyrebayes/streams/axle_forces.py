"""Step 4 of the signal pipeline: axle forces from the force balance (eqs. 4.22/4.23), the
normalised forces ρ_x and their noise.

Called by :func:`tyrebayes.streams.features.compute_features`.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..internal.device_arrays import device_array
from ..physics.vehicle import (
    Vehicle,
    aero_drag,
    axle_loads,
    rolling_resistance_force,
    single_track_inverse,
)
from .filters import PrefixSums, window_samples
from .imu_calibration import _ImuCalibration
from .motion import _columns, _Motion, _Scales, _table
from .noise import local_noise_sd
from .wheel_noise import _slip_noise_probe, _WheelNoise

# Low-pass of IMU a_x − dV_x/dt that carries the road grade into the traction force [s]: hills
# change over hundreds of metres (tens of seconds), the IMU's coloured noise over seconds.
GRADE_LOWPASS_S = 10.0


def _traction_acceleration(
    vx: PrefixSums,
    ax_imu: np.ndarray,
    vx_probe: PrefixSums,
    drive: str,
    dt: float,
    window: int,
    rate: float,
    span: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Longitudinal specific force for the traction force, and its noise sd [m/s²].

    The IMU's a_x carries coloured noise and vibration over 0.2-1 s, the scale of real changes of
    acceleration, so that neither a high-pass nor the smoothing tells them apart; on drives from
    an independent generator its window error was 0.011-0.047 of ρ_x, as large as
    the window's stated noise and, in the slip-on-force regression, an attenuation of the slope.
    Where V_x comes from free-rolling wheels (FWD, RWD) their dV_x/dt measures the same
    acceleration with the wheel speeds' far smaller noise, and only
    what it lacks, g·sin(grade) (with the IMU offset left after correction), comes from the IMU,
    low-passed over :data:`GRADE_LOWPASS_S`: a complementary filter. For AWD cars no wheel rolls
    freely and the IMU is used as it is.

    The noise is the local RMS of the same derivative of the V_x wheels' difference (the motion
    cancels, their noise does not), with the IMU's share through the low-pass added.
    """
    if drive == "awd":
        return ax_imu, np.full_like(ax_imu, np.nan)
    dvx_dt = vx.smoothed_derivative(window // 2, dt)
    lowpass = window_samples(GRADE_LOWPASS_S, rate)
    # The IMU's error with the motion removed (a_x − dV_x/dt): its low-pass is the grade term,
    # its noise through the low-pass the IMU's share of the error (one set of prefix sums).
    imu_error = ax_imu - dvx_dt
    imu_error_sums = PrefixSums.of(imu_error)
    grade_accel = imu_error_sums.window_mean(lowpass // 2)
    probe = vx_probe.smoothed_derivative(window // 2, dt)
    probe_sums = PrefixSums.of(probe)
    probe -= probe_sums.window_mean(span // 2)
    # probe² has probe's NaN: the same counts.
    derivative_sd = np.sqrt(PrefixSums.of(probe**2, like=probe_sums).window_mean(span // 2))
    imu_sd = local_noise_sd(imu_error, window, span, prefix=imu_error_sums)
    imu_sd *= np.sqrt(window / lowpass)
    return dvx_dt + grade_accel, np.hypot(derivative_sd, imu_sd)


# Fixed chunk length for the JAX force balance: one compilation per process serves logs of any
# length (a new shape would recompile), and the cost stays linear in duration.
_CHUNK = 65536


class _AxleForces(eqx.Module):
    """The force balance of every sample, for the IMU's a_x and for the traction a_x [N].

    Per-axle pairs (front, rear) are (n, 2) views of one block, columns contiguous.
    """

    resistance: Float[np.ndarray, "n"]  # drag + rolling resistance
    fx_axle: Float[np.ndarray, "n 2"]  # traction split, or the brake balance under braking
    fz_axle: Float[np.ndarray, "n 2"]
    fx_traction: Float[np.ndarray, "n 2"]  # traction a_x, traction split at every sample
    fz_traction: Float[np.ndarray, "n 2"]


@eqx.filter_jit
def _force_balance_chunk(
    vehicle: Vehicle,
    braking_vehicle: Vehicle,
    ax: Float[Array, " c"],
    ax_traction: Float[Array, " c"],
    ay: Float[Array, " c"],
    yaw_acc: Float[Array, " c"],
    steer: Float[Array, " c"],
    speed: Float[Array, " c"],
) -> tuple[Float[Array, " c"], ...]:
    # Missing samples count as 0 (np.nan_to_num), a missing or negative speed as standstill
    # for the drag; done here, fused into the chunk's one pass, not as copies of whole logs.
    ax, ax_traction, ay, yaw_acc, steer = (
        jnp.nan_to_num(a) for a in (ax, ax_traction, ay, yaw_acc, steer)
    )
    speed = jnp.where(jnp.isfinite(speed), jnp.maximum(speed, 0.0), 0.0)
    resistance = aero_drag(vehicle, speed) + rolling_resistance_force(vehicle)
    fxf_t, _, fxr_t, _ = single_track_inverse(vehicle, ax, ay, yaw_acc, steer, resistance)
    fxf_b, _, fxr_b, _ = single_track_inverse(braking_vehicle, ax, ay, yaw_acc, steer, resistance)
    braking = vehicle.mass_kg * ax + resistance < 0.0
    fz_front, fz_rear = axle_loads(vehicle, ax)
    fxf_tt, _, fxr_tt, _ = single_track_inverse(
        vehicle, ax_traction, ay, yaw_acc, steer, resistance
    )
    fzf_tt, fzr_tt = axle_loads(vehicle, ax_traction)
    return (
        resistance,
        jnp.where(braking, fxf_b, fxf_t),
        jnp.where(braking, fxr_b, fxr_t),
        fz_front,
        fz_rear,
        fxf_tt,
        fxr_tt,
        fzf_tt,
        fzr_tt,
    )


def _force_balance(
    vehicle: Vehicle,
    ax: np.ndarray,
    ax_traction: np.ndarray,
    ay: np.ndarray,
    yaw_acc: np.ndarray,
    steer: np.ndarray,
    speed: np.ndarray,
    brake_front_share: float,
) -> _AxleForces:
    """Resistance, axle forces and loads for two a_x signals on the same motion [N].

    Eq. 4.23 inverted by :func:`single_track_inverse`: with ``ax``, traction follows the drive's
    split, braking the brake balance (front share), a property of the brake system, not of the
    drive; with ``ax_traction``, the traction split at every sample. One pass over the chunks
    serves both (the steering's sin/cos and the resistance are shared). NaN in the inputs
    counts as 0, and a missing or negative ``speed`` as standstill for the drag.
    """
    braking_vehicle = dataclasses.replace(
        vehicle, drive="awd", front_drive_fraction=float(brake_front_share)
    )
    n = ax.shape[0]
    inputs = (ax, ax_traction, ay, yaw_acc, steer, speed)
    # The chunk's outputs, a row each: the features keep the first block (resistance, axle
    # forces and loads), the traction block is an intermediate, freed after the forces step.
    kept, traction = np.empty((5, n)), np.empty((4, n))
    out = [*kept, *traction]
    for i in range(0, n, _CHUNK):
        size = min(_CHUNK, n - i)
        chunk = [a[i : i + size] for a in inputs]
        if size < _CHUNK:  # the last chunk, padded with zeros to the fixed length
            chunk = [np.pad(c, (0, _CHUNK - size)) for c in chunk]
        parts = _force_balance_chunk(vehicle, braking_vehicle, *(device_array(c) for c in chunk))
        for row, part in zip(out, parts, strict=True):
            row[i : i + size] = np.asarray(part)[:size]
    return _AxleForces(
        resistance=kept[0],
        fx_axle=kept[1:3].T,
        fz_axle=kept[3:5].T,
        fx_traction=traction[:2].T,
        fz_traction=traction[2:].T,
    )


class _Forces(eqx.Module):
    """Step 4: axle forces from the force balance, normalised forces and their noise."""

    resistance: Float[np.ndarray, "n"]  # drag + rolling resistance [N]
    fx_axle: Float[np.ndarray, "n 2"]  # [N]
    fz_axle: Float[np.ndarray, "n 2"]  # [N]
    rho_axle: Float[np.ndarray, "n 2"]
    fx_driven: Float[np.ndarray, "n"]  # [N]
    fz_driven: Float[np.ndarray, "n"]  # [N]
    rho_driven: Float[np.ndarray, "n"]
    rho_driven_sd: Float[np.ndarray, "n"]
    rho_driven_traction: Float[np.ndarray, "n"]
    rho_driven_traction_sd: Float[np.ndarray, "n"]
    rho_total_traction: Float[np.ndarray, "n"]
    load_change_driven: Float[np.ndarray, "n"]  # ΔF_z/F_z,static, traction a_x
    slip_driven_noise: Float[np.ndarray, "n"]  # driven slip-velocity noise [m/s]
    slip_driven_sd: Float[np.ndarray, "n"]
    ax_sd_local: Float[np.ndarray, "n"]  # noise of the smoothed, corrected ax [m/s²]


def _forces(
    stream,
    vehicle,
    motion: _Motion,
    noise: _WheelNoise,
    imu: _ImuCalibration,
    scales: _Scales,
    brake_front_share: float,
) -> _Forces:
    """Step 4: axle forces, the driven axle's normalised forces and their noise."""
    m, window, span = motion, scales.window, scales.span
    ax_traction, ax_traction_sd = _traction_acceleration(
        m.vx_prefix, imu.ax, noise.vx_probe, vehicle.drive, scales.dt_s, window,
        scales.rate_hz, span,
    )  # fmt: skip
    balance = _force_balance(
        vehicle, imu.ax, ax_traction, imu.ay, imu.yaw_acc, m.steer, m.vx, brake_front_share,
    )  # fmt: skip
    resistance, fx_axle, fz_axle = balance.resistance, balance.fx_axle, balance.fz_axle
    no_force = ~(m.valid & np.isfinite(imu.ax))
    for i in range(2):
        fx_axle[no_force, i] = np.nan
    fx_driven, fz_driven = _driven(vehicle, fx_axle), _driven(vehicle, fz_axle)
    has_traction = m.valid & np.isfinite(ax_traction)
    traction = _traction_ratios(vehicle, balance, has_traction)
    slip_driven_noise = _slip_noise(noise, m, traction, window, span)
    # Per-sample noise of the smoothed ax, scaled by the axle's share of m·ax. The offset's
    # uncertainty is common to the whole log and reported apart (nuisances.rho_offset_sd).
    ax_raw = stream.data["ax"].to_numpy(dtype=float)
    ax_sd_local = local_noise_sd(ax_raw, window, span, prefix=m.ax_prefix) / (
        imu.pitch_gain * imu.imu_gain.applied
    )
    share = _driven_share(fx_axle, fx_driven)
    return _Forces(
        resistance=resistance,
        fx_axle=fx_axle,
        fz_axle=fz_axle,
        rho_axle=np.divide(fx_axle, fz_axle, out=_table(*fx_axle.shape)),
        fx_driven=fx_driven,
        fz_driven=fz_driven,
        rho_driven=fx_driven / fz_driven,
        rho_driven_sd=vehicle.mass_kg * ax_sd_local * np.maximum(share, 0.5) / fz_driven,
        rho_driven_traction=traction.rho_driven,
        rho_driven_traction_sd=(
            vehicle.mass_kg
            * np.where(np.isfinite(ax_traction_sd), ax_traction_sd, ax_sd_local)
            / traction.fz_driven
        ),
        rho_total_traction=traction.rho_total,
        load_change_driven=traction.load_change_driven,
        slip_driven_noise=slip_driven_noise,
        slip_driven_sd=slip_driven_noise / m.vx_safe,
        ax_sd_local=ax_sd_local,
    )


def _driven(vehicle: Vehicle, per_axle: np.ndarray) -> np.ndarray:
    """The driven axle's column, or the sum of both for AWD."""
    if vehicle.driven_axle == "both":
        return per_axle.sum(axis=1)
    return per_axle[:, 0 if vehicle.driven_axle == "front" else 1]


class _TractionRatios(NamedTuple):
    """Normalised forces and load change of the traction force (NaN where it is not known)."""

    fz_driven: np.ndarray  # the driven axle's load [N]
    rho_driven: np.ndarray  # the driven axle's force over its load [-]
    rho_total: np.ndarray  # both axles' force over both loads [-]
    load_change_driven: np.ndarray  # ΔF_z/F_z,static of the driven axle [-]


def _traction_ratios(
    vehicle: Vehicle, balance: _AxleForces, has_traction: np.ndarray
) -> _TractionRatios:
    """The traction force's normalised forces and the driven axle's load change."""
    fx_traction, fz_traction = balance.fx_traction, balance.fz_traction
    fx_traction_driven = _driven(vehicle, fx_traction)
    fz_traction_driven = _driven(vehicle, fz_traction)
    rho_driven_traction = np.where(has_traction, fx_traction_driven / fz_traction_driven, np.nan)
    rho_total_traction = np.where(
        has_traction,
        (fx_traction[:, 0] + fx_traction[:, 1]) / (fz_traction[:, 0] + fz_traction[:, 1]),
        np.nan,
    )
    static_front, static_rear = (float(v) for v in axle_loads(vehicle, 0.0))
    static_driven = {"front": static_front, "rear": static_rear}.get(
        vehicle.driven_axle, static_front + static_rear
    )
    load_change_driven = np.where(has_traction, fz_traction_driven / static_driven - 1.0, np.nan)
    return _TractionRatios(
        fz_traction_driven, rho_driven_traction, rho_total_traction, load_change_driven
    )


def _slip_noise(
    noise: _WheelNoise, m: _Motion, traction: _TractionRatios, window: int, span: int
) -> np.ndarray:
    """Local noise of the driven wheels' slip velocity [m/s], where the tyres push or brake."""
    pushing = traction.rho_total >= 0.0
    velocity = PrefixSums.of(noise.slip_velocity_driven, like=m.vx_prefix)
    slip_driven_noise = local_noise_sd(
        _columns(
            _slip_noise_probe(
                noise.slip_velocity_driven,
                velocity,
                traction.rho_driven * m.vx_safe,
                pushing,
                window,
            ),
            noise.slip_velocity_driven,
        ),
        window,
        span,
        prefix=(None, velocity),
    )
    # Where the tyres brake (no slip window there) the plain slip velocity's noise stands in.
    return np.where(
        np.isfinite(slip_driven_noise[:, 0]), slip_driven_noise[:, 0], slip_driven_noise[:, 1]
    )


def _driven_share(fx_axle: np.ndarray, fx_driven: np.ndarray) -> np.ndarray:
    """The driven axle's share of the axles' total force, in [0, 1] (1 where it is 0)."""
    fx_total = np.abs(fx_axle[:, 0] + fx_axle[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(fx_total > 0, np.abs(fx_driven) / fx_total, 1.0)
    return np.clip(np.nan_to_num(share, nan=1.0), 0.0, 1.0)
