"""A small kinematic test-signal generator for the stream pipeline (tests and benchmarks).

Not the vehicle simulator (that is :mod:`tyrebayes.simulate`): here the motion is prescribed
(smooth speed and steering profiles), the tyre is linear (σ = ρ / C_x) and the sensors are
ideal-plus-nuisances, so every feature has a closed-form truth. It exercises exactly what the
pipeline must undo: per-wheel radius errors, wheel-speed quantisation and noise, IMU offset and
noise, road grade, dropped samples (negate ay, yaw_rate and az for a z-down IMU).

Examples
--------
>>> from tyrebayes._domain import load_vehicle
>>> df, truth = synthetic_stream(load_vehicle("compact_fwd"), duration_s=10.0, seed=0)
>>> df.shape[0], round(float(truth["vx_mps"].mean()))
(1000, 15)
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pandas as pd

from ..physics.vehicle import GRAVITY_MPS2, Vehicle, body_pitch_gain
from .motion import REAR_CORNERING_PER_RAD

_KMH_STEP = 0.01 / 3.6  # CAN wheel-speed resolution of 0.01 km/h, in m/s


def _relative_slip(slip: np.ndarray, drive: str) -> np.ndarray:
    """The driven wheels' slip relative to the free wheels' (0 for AWD)."""
    if drive == "awd":
        return np.zeros(slip.shape[0])
    driven, free = ((0, 1), (2, 3)) if drive == "fwd" else ((2, 3), (0, 1))
    return (1.0 + slip[:, driven].mean(axis=1)) / (1.0 + slip[:, free].mean(axis=1)) - 1.0


def synthetic_stream(
    vehicle: Vehicle,
    *,
    duration_s: float = 60.0,
    rate_hz: float = 100.0,
    seed: int = 0,
    c_x: float = 40.0,
    radius_error_sd: float = 0.002,
    wheel_noise_radps: float = 0.02,
    quantise: bool = True,
    ax_offset_mps2: float = -0.3,
    imu_noise_mps2: float = 0.2,
    grade_amplitude_rad: float = 0.01,
    drop_fraction: float = 0.0,
    brake_front_share: float = 0.7,
    speed_reference: bool = True,
    accel_ripple_mps2: float = 0.0,
    accel_ripple_hz: float = 0.7,
) -> tuple[pd.DataFrame, dict[str, np.ndarray | float]]:
    """A stream file's table and its truth.

    Parameters
    ----------
    vehicle : Vehicle
        Geometry, mass, drive and radius of the car.
    duration_s, rate_hz : float
        Length [s] and sample rate [Hz].
    seed : int
        Seed of the NumPy generator (profiles' phases and all noise).
    c_x : float
        Linear slip stiffness of the tyres: σ = ρ_x / C_x.
    radius_error_sd : float
        Relative sd of the per-wheel rolling radius errors.
    wheel_noise_radps : float
        White noise of the wheel speeds before quantisation [rad/s].
    quantise : bool
        Round wheel speeds to 0.01 km/h steps (as CAN does).
    ax_offset_mps2 : float
        IMU longitudinal offset (bias + mounting pitch) [m/s²].
    imu_noise_mps2 : float
        White noise of ax and ay [m/s²].
    grade_amplitude_rad : float
        Amplitude of a slow sinusoidal road grade [rad].
    drop_fraction : float
        Fraction of rows where one random channel is NaN (a dropped sample).
    brake_front_share : float
        Front share of the braking force.
    speed_reference : bool
        Add a GNSS-like ``speed_reference`` column (0.05 m/s noise).
    accel_ripple_mps2, accel_ripple_hz : float
        Amplitude [m/s²] and frequency [Hz] of a fast sinusoidal change of acceleration on top
        of the slow profile: real drivers change the force over 0.2-1 s, the scale at which the
        pipeline measures noise.

    Returns
    -------
    (DataFrame, dict)
        The stream table in the contract, and the truth: ``time``, ``vx_mps``, ``ax_mps2``
        (dV/dt), ``grade_rad``, ``slip_driven`` (mean over the driven wheels),
        ``slip_driven_relative`` (relative to the V_x wheels, what wheel speeds show),
        ``rho_driven``, ``front_load_change`` (ΔF_z/F_z,static of the front axle),
        ``radius_error`` (4,), ``ax_offset_mps2``.
    """
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz))
    t = np.arange(n) / rate_hz
    ph = rng.uniform(0, 2 * np.pi, 6)
    motion = _motion(vehicle, t, ph, grade_amplitude_rad, accel_ripple_mps2, accel_ripple_hz)
    forces = _axle_forces(vehicle, motion, brake_front_share)
    slip = (
        np.column_stack([forces.rho_front, forces.rho_front, forces.rho_rear, forces.rho_rear])
        / c_x
    )
    radius_error = rng.normal(0.0, radius_error_sd, 4)
    omega = _wheel_speeds(rng, vehicle, motion, slip, radius_error, wheel_noise_radps, quantise)
    table = _sensor_table(
        rng, vehicle, motion, omega, ax_offset_mps2, imu_noise_mps2, speed_reference
    )
    df = pd.DataFrame(table)
    if drop_fraction > 0:
        _drop_samples(rng, df, drop_fraction)
    return df, _truth(vehicle, motion, forces, slip, radius_error, ax_offset_mps2)


class _Kinematics(NamedTuple):
    """The prescribed motion of the car, sample by sample."""

    time: np.ndarray  # [s]
    vx: np.ndarray  # speed [m/s]
    ax: np.ndarray  # dV/dt [m/s²]
    steer: np.ndarray  # road-wheel angle [rad]
    yaw: np.ndarray  # yaw rate [rad/s]
    yaw_acc: np.ndarray  # yaw acceleration [rad/s²]
    ay: np.ndarray  # lateral acceleration [m/s²]
    grade: np.ndarray  # road grade [rad]


def _motion(
    vehicle: Vehicle,
    t: np.ndarray,
    ph: np.ndarray,
    grade_amplitude_rad: float,
    accel_ripple_mps2: float,
    accel_ripple_hz: float,
) -> _Kinematics:
    """Smooth speed, steering and grade profiles with the phases ``ph``, and the yaw they give."""
    w = 2 * np.pi * np.array([0.01, 0.05, 0.13])
    amp = np.array([6.0, 3.0, 1.0])
    ripple_w = 2 * np.pi * accel_ripple_hz
    vx = 20.0 + sum(amp[k] * np.sin(w[k] * t + ph[k]) for k in range(3))
    ax_true = sum(amp[k] * w[k] * np.cos(w[k] * t + ph[k]) for k in range(3))
    if accel_ripple_mps2:
        vx = vx + accel_ripple_mps2 / ripple_w * np.sin(ripple_w * t)
        ax_true = ax_true + accel_ripple_mps2 * np.cos(ripple_w * t)
    steer = 0.012 * np.sin(2 * np.pi * 0.07 * t + ph[3]) + 0.006 * np.sin(
        2 * np.pi * 0.17 * t + ph[4]
    )
    understeer = 0.002  # s²/m², a mildly understeering car
    yaw = vx * steer / (vehicle.wheelbase_m * (1.0 + understeer * vx**2))
    yaw_acc = np.gradient(yaw, t)
    ay_true = vx * yaw
    grade = grade_amplitude_rad * np.sin(2 * np.pi * t / 120.0 + ph[5])
    return _Kinematics(t, vx, ax_true, steer, yaw, yaw_acc, ay_true, grade)


class _AxleForces(NamedTuple):
    """The tyres' total force and each axle's load and normalised force."""

    f_total: np.ndarray  # [N]
    fz_front: np.ndarray  # [N]
    fz_rear: np.ndarray  # [N]
    rho_front: np.ndarray  # [-]
    rho_rear: np.ndarray  # [-]


def _axle_forces(vehicle: Vehicle, motion: _Kinematics, brake_front_share: float) -> _AxleForces:
    """The force balance: the tyres' force, split between the axles, over their loads."""
    ax_true, grade, vx = motion.ax, motion.grade, motion.vx
    m, g = vehicle.mass_kg, GRAVITY_MPS2
    resistance = 0.6 * vehicle.drag_area_m2 * vx**2 + vehicle.rolling_resistance * m * g
    f_total = m * ax_true + m * g * np.sin(grade) + resistance
    share = np.where(f_total >= 0, vehicle.traction_front_share, brake_front_share)
    # Lateral force needs part of the front-wheel steer angle; at these small δ its longitudinal
    # projection is below 1 % and the truth keeps eq. 4.23's simplest form.
    fx_front, fx_rear = share * f_total, (1.0 - share) * f_total
    h_over_l = vehicle.cog_height_m / vehicle.wheelbase_m
    fz_front = (
        m * g * vehicle.cog_to_rear_axle_m / vehicle.wheelbase_m
        - m * (ax_true + g * np.sin(grade)) * h_over_l
    )
    fz_rear = m * g - fz_front
    rho_front, rho_rear = fx_front / fz_front, fx_rear / fz_rear
    return _AxleForces(f_total, fz_front, fz_rear, rho_front, rho_rear)


def _wheel_speeds(
    rng: np.random.Generator,
    vehicle: Vehicle,
    motion: _Kinematics,
    slip: np.ndarray,
    radius_error: np.ndarray,
    wheel_noise_radps: float,
    quantise: bool,
) -> np.ndarray:
    """Logged wheel speeds (n, 4) [rad/s]: wheel-centre speeds with slip, radius errors, noise."""
    vx, yaw, steer = motion.vx, motion.yaw, motion.steer
    g = GRAVITY_MPS2
    # The body's sideslip of a steady turn (single-track model): the rear axle moves sideways at
    # −α_r V_x, so the front axle's lateral speed is ψ̇ L − α_r V_x; the rear slip angle takes
    # the cornering stiffness the features assume, so this term's truth is theirs.
    half = 0.5 * vehicle.track_width_m
    rear_slip_angle = motion.ay / (g * REAR_CORNERING_PER_RAD)
    front_lat = yaw * vehicle.wheelbase_m - rear_slip_angle * vx
    u = np.column_stack(
        [
            (vx - yaw * half) * np.cos(steer) + front_lat * np.sin(steer),
            (vx + yaw * half) * np.cos(steer) + front_lat * np.sin(steer),
            vx - yaw * half,
            vx + yaw * half,
        ]
    )
    radius = vehicle.wheel_radius_m * (1.0 + radius_error)
    omega = u * (1.0 + slip) / radius[None, :]
    omega = omega + rng.normal(0.0, wheel_noise_radps, omega.shape)
    if quantise:
        step = _KMH_STEP / vehicle.wheel_radius_m
        omega = np.round(omega / step) * step
    return omega


def _sensor_table(
    rng: np.random.Generator,
    vehicle: Vehicle,
    motion: _Kinematics,
    omega: np.ndarray,
    ax_offset_mps2: float,
    imu_noise_mps2: float,
    speed_reference: bool,
) -> dict[str, np.ndarray]:
    """The stream's columns: wheel speeds, noisy IMU and steering, optional GNSS speed."""
    n, g = motion.time.shape[0], GRAVITY_MPS2
    table = {
        "time": motion.time,
        "wheel_speed_fl": omega[:, 0],
        "wheel_speed_fr": omega[:, 1],
        "wheel_speed_rl": omega[:, 2],
        "wheel_speed_rr": omega[:, 3],
        # The body squats and dives by k·a_x: to first order the IMU reads a_x (1 + g·k).
        "ax": motion.ax * float(body_pitch_gain(vehicle))
        + g * np.sin(motion.grade)
        + ax_offset_mps2
        + rng.normal(0, imu_noise_mps2, n),
        "ay": motion.ay + rng.normal(0, imu_noise_mps2, n),
        "yaw_rate": motion.yaw + rng.normal(0, 0.002, n),
        "steering_wheel_angle": motion.steer * vehicle.steering_ratio + rng.normal(0, 0.002, n),
        "az": g + rng.normal(0, imu_noise_mps2, n),
    }
    if speed_reference:
        table["speed_reference"] = motion.vx + rng.normal(0, 0.05, n)
    return table


def _drop_samples(rng: np.random.Generator, df: pd.DataFrame, drop_fraction: float) -> None:
    """Set one random channel of about ``drop_fraction`` of the rows to NaN, in place."""
    n = df.shape[0]
    cols = [c for c in df.columns if c != "time"]
    rows = np.flatnonzero(rng.random(n) < drop_fraction)
    which = rng.integers(0, len(cols), rows.size)
    for j, col in enumerate(cols):
        df.loc[rows[which == j], col] = np.nan


def _truth(
    vehicle: Vehicle,
    motion: _Kinematics,
    forces: _AxleForces,
    slip: np.ndarray,
    radius_error: np.ndarray,
    ax_offset_mps2: float,
) -> dict[str, np.ndarray | float]:
    """The truth of :func:`synthetic_stream` (its Returns section)."""
    m, g = vehicle.mass_kg, GRAVITY_MPS2
    driven = {"front": [0, 1], "rear": [2, 3], "both": [0, 1, 2, 3]}[vehicle.driven_axle]
    if vehicle.driven_axle == "both":
        rho_driven = forces.f_total / (forces.fz_front + forces.fz_rear)
    else:
        rho_driven = forces.rho_front if vehicle.driven_axle == "front" else forces.rho_rear
    return {
        "time": motion.time,
        "vx_mps": motion.vx,
        "ax_mps2": motion.ax,
        "grade_rad": motion.grade,
        "yaw_acc_radps2": motion.yaw_acc,
        "slip_driven": slip[:, driven].mean(axis=1),
        # What wheel speeds can show: the driven wheels' slip relative to the wheels that give
        # V_x (non-driven wheels slip too when they brake).
        "slip_driven_relative": _relative_slip(slip, vehicle.drive),
        "rho_driven": rho_driven,
        # The front axle's load over its static load, minus 1.
        "front_load_change": forces.fz_front
        / (m * g * vehicle.cog_to_rear_axle_m / vehicle.wheelbase_m)
        - 1.0,
        "radius_error": radius_error,
        "ax_offset_mps2": float(ax_offset_mps2),
    }
