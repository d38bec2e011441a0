"""Sensor model of a simulated drive: what a CAN bus, an IMU and a GNSS receiver would log.

Defaults resemble the real RAV4 log shipped in ``tyrebayes/data/comma2k19_rav4_segment.csv``
(measured by ``benchmarks/real_vs_sim.py``):

* wheel speeds quantised to 0.01 km/h of CAN wheel speed (0.00794 rad/s at R = 0.35 m — the step
  found in the real log), white noise plus an axle-correlated vibration (broad ~8 Hz front,
  12.5 Hz rear, as in the real log) whose level varies with road roughness by a factor of 2–3
  within a minute, and road bumps that ring the front wheels, then the rear ones a wheelbase
  later (the real log's heavy tails);
* IMU accelerations with ~0.2 m/s² white noise plus a 12 Hz vehicle vibration (a dashcam IMU; an
  ESC IMU is ~10× cleaner), a bias, a mounting pitch (ax includes g·sin(pitch + grade)) and
  suspension pitch with acceleration;
* yaw-rate noise 1.5 mrad/s; steering quantised to 0.1°;
* jittered time stamps (the real log's interval has a 34 % coefficient of variation);
* GNSS speed at 20 Hz, zero-order held (or interpolated), ~0.02 m/s noise;
* dropped samples as NaN (single samples per channel and bursts over the whole bus).

:meth:`SensorModel.rav4_comma2k19` adds the real log's specific offsets (mounting pitch, an ax
gain of 0.79, radius errors, irregular timing). Known remaining differences are listed in
``benchmarks/results/real_vs_sim.json`` and the final report.

All NumPy, vectorised; one hour at 100 Hz takes well under a second.

Examples
--------
>>> SensorModel().wheel_speed_resolution_kmh
0.01
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from ..physics.vehicle import GRAVITY_MPS2
from .noise_processes import ou_process
from .sensor_model import WHEELS as WHEELS
from .sensor_model import SensorModel as SensorModel
from .sensor_model import SensorTruth as SensorTruth
from .sensor_model import draw_sensor_truth as draw_sensor_truth
from .sensor_model import scale_noise as scale_noise


def sample_times(
    rng: np.random.Generator, n: int, sample_rate_hz: float, jitter: float
) -> np.ndarray:
    """Logged time stamps: the nominal grid plus uniform jitter (strictly increasing for < 0.5).

    Examples
    --------
    >>> t = sample_times(np.random.default_rng(0), 1000, 100.0, 0.4)
    >>> bool(np.all(np.diff(t) > 0))
    True
    """
    dt = 1.0 / sample_rate_hz
    t = np.arange(n) * dt
    if jitter > 0:
        t = t + rng.uniform(-jitter, jitter, n) * dt
        t[0] = 0.0
    return t


def _resonance(
    rng: np.random.Generator, shape: tuple[int, ...], f_hz: float, dt: float, zeta: float = 0.2
) -> np.ndarray:
    """Unit-variance band noise: white noise through a damped 2nd-order resonator (damping ζ)."""
    w = 2 * np.pi * min(f_hz, 0.4 / dt)  # keep below Nyquist
    r = np.exp(-zeta * w * dt)
    a = [1.0, -2 * r * np.cos(w * dt * np.sqrt(1 - zeta**2)), r**2]
    x = lfilter([1.0], a, rng.standard_normal(shape), axis=0)
    return x / max(float(np.std(x)), 1e-12)


def _bumps(
    rng: np.random.Generator,
    sensor: SensorModel,
    speed_mps: np.ndarray,
    dt: float,
    wheelbase_m: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Wheel-speed (n, 4) and IMU (n, 3) disturbances of road bumps (damped 12 Hz ringing)."""
    n = len(speed_mps)
    wheels, imu = np.zeros((n, 4)), np.zeros((n, 3))
    distance_km = float(np.sum(speed_mps) * dt / 1000.0)
    k = rng.poisson(sensor.bumps_per_km * distance_km)
    if k == 0 or sensor.bump_amplitude_radps == 0:
        return wheels, imu
    # Bumps are spread over distance: pick sample indices with probability ∝ speed.
    cdf = np.cumsum(speed_mps)
    idx = np.searchsorted(cdf, rng.random(k) * cdf[-1])
    # Log-normal sizes, capped at 6× the median (the real log's largest bump is ~5× its typical one;
    # an uncapped tail would produce IMU readings no car survives).
    amp = sensor.bump_amplitude_radps * np.exp(np.minimum(rng.standard_normal(k), np.log(6.0)))
    sign = rng.choice([-1.0, 1.0], k)
    side = rng.choice(3, k)  # 0 left, 1 right, 2 both
    left = np.where(side == 1, 0.3, 1.0)
    right = np.where(side == 0, 0.3, 1.0)
    delay = np.round(wheelbase_m / np.maximum(speed_mps[idx], 1.0) / dt).astype(int)
    rear = np.minimum(idx + delay, n - 1)
    impulses = np.zeros((n, 4))
    np.add.at(impulses[:, 0], idx, amp * sign * left)
    np.add.at(impulses[:, 1], idx, amp * sign * right)
    np.add.at(impulses[:, 2], rear, 1.5 * amp * sign * left)
    np.add.at(impulses[:, 3], rear, 1.5 * amp * sign * right)
    # Damped ringing: h[k] = r^k sin(ω k dt) as a two-pole filter (decay 0.08 s, 12 Hz).
    r = np.exp(-dt / 0.08)
    w = 2 * np.pi * min(12.0, 0.4 / dt) * dt
    b, a = [0.0, r * np.sin(w)], [1.0, -2 * r * np.cos(w), r**2]
    wheels = lfilter(b, a, impulses, axis=0)
    hits = np.abs(impulses).sum(axis=1) * np.sign(impulses.sum(axis=1))
    ring = lfilter(b, a, hits)
    imu = ring[:, None] * np.array([1.2, 0.5, 1.5])[None, :]
    return wheels, imu


def _quantise(x: np.ndarray, step: float) -> np.ndarray:
    """``x`` rounded to multiples of ``step`` (unchanged for a step of 0)."""
    return np.round(x / step) * step if step > 0 else x


def measure(
    rng: np.random.Generator,
    sensor: SensorModel,
    offsets: SensorTruth,
    *,
    time_s: np.ndarray,
    wheel_speed_radps: np.ndarray,
    accel_mps2: np.ndarray,
    ay_mps2: np.ndarray,
    grade_rad: np.ndarray,
    yaw_rate_radps: np.ndarray,
    steering_wheel_angle_rad: np.ndarray,
    speed_mps: np.ndarray,
    ambient_c: float,
    wheelbase_m: float = 2.7,
    pitch_gradient_rad_per_mps2: float = 0.0,
) -> pd.DataFrame:
    """Turn true signals at the logged times into the logged stream (DESIGN.md stream contract).

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    sensor : SensorModel
        Noise, quantisation and dropouts.
    offsets : SensorTruth
        The drive's offsets (see :func:`draw_sensor_truth`).
    time_s : (n,) array
        Logged time stamps [s].
    wheel_speed_radps : (n, 4) array
        True wheel angular speeds Ω (fl, fr, rl, rr) [rad/s] (radius errors already applied).
    accel_mps2 : (n,) array
        True longitudinal acceleration dV_x/dt of the body [m/s²] (no gravity).
    ay_mps2 : (n,) array
        True lateral acceleration [m/s²].
    grade_rad : (n,) array
        Road grade [rad], positive uphill.
    yaw_rate_radps, steering_wheel_angle_rad, speed_mps : (n,) arrays
        True yaw rate [rad/s], steering-wheel angle [rad] and ground speed [m/s].
    ambient_c : float
        Ambient temperature [°C].
    wheelbase_m : float
        Wheelbase [m]: a bump reaches the rear wheels a wheelbase after the front ones.
    pitch_gradient_rad_per_mps2 : float
        The vehicle's body pitch per unit acceleration (squat/dive) [rad/(m/s²)].

    Returns
    -------
    pandas.DataFrame
        Columns ``time``, ``wheel_speed_fl..rr``, ``ax``, ``ay``, ``az``, ``yaw_rate``,
        ``steering_wheel_angle``, ``ambient_temperature`` and (if ``gnss_rate_hz`` > 0)
        ``speed_reference``. NaN marks dropped samples.
    """
    n = len(time_s)
    dt = float(np.median(np.diff(time_s))) if n > 1 else 0.01
    duration = float(time_s[-1] - time_s[0]) if n > 1 else dt
    rough = _roughness(rng, sensor, n, dt)

    # Wheel speeds: vibration partly common to an axle, plus white noise, then CAN quantisation
    # (the CAN value is a speed; the logger divides by the nominal radius).
    wheel_noise = _wheel_noise(rng, sensor, n, dt)
    bump_wheels, bump_imu = _bumps(rng, sensor, np.asarray(speed_mps, dtype=float), dt, wheelbase_m)
    # Road-induced speed fluctuations vanish at standstill (and a wheel-speed sensor reports a
    # magnitude, never a negative speed).
    moving = np.clip(np.asarray(speed_mps) / 5.0, 0.0, 1.0)
    omega = wheel_speed_radps + wheel_noise * (rough * moving)[:, None] + bump_wheels
    omega = np.maximum(_quantise(omega, offsets.wheel_speed_step_radps), 0.0)

    # Vehicle vibration (one mode, three axes) and white noise, both scaled by road roughness and
    # fading out at standstill like the wheel noise.
    shake = (rough * np.maximum(moving, 0.2))[:, None]
    ax, ay, az = _imu(
        rng, sensor, offsets, accel_mps2, ay_mps2, grade_rad, shake, bump_imu, dt,
        pitch_gradient_rad_per_mps2,
    )  # fmt: skip
    yaw = (
        yaw_rate_radps
        + offsets.yaw_rate_bias_radps
        + sensor.yaw_rate_noise_radps * rng.standard_normal(n)
    )
    steer = _quantise(
        steering_wheel_angle_rad + sensor.steering_noise_rad * rng.standard_normal(n),
        sensor.steering_resolution_rad,
    )
    ambient = _quantise(np.full(n, float(ambient_c)), sensor.ambient_resolution_c)

    columns: dict[str, np.ndarray] = {"time": np.asarray(time_s, dtype=float)}
    for i, w in enumerate(WHEELS):
        columns[f"wheel_speed_{w}"] = omega[:, i]
    columns.update(ax=ax, ay=ay, az=az, yaw_rate=yaw, steering_wheel_angle=steer)
    columns["ambient_temperature"] = ambient
    if sensor.gnss_rate_hz > 0:
        columns["speed_reference"] = _gnss_speed(rng, sensor, time_s, speed_mps, duration)

    _drop(rng, sensor, columns, dt, duration)
    return pd.DataFrame(columns)


def _roughness(rng: np.random.Generator, sensor: SensorModel, n: int, dt: float) -> np.ndarray:
    """Road roughness: a log-normal factor (mean 1) on the road-induced noise, per sample."""
    return (
        np.exp(
            ou_process(rng, n, dt, 10.0, sensor.roughness_log_sd) - 0.5 * sensor.roughness_log_sd**2
        )
        if sensor.roughness_log_sd > 0
        else np.ones(n)
    )


def _wheel_noise(rng: np.random.Generator, sensor: SensorModel, n: int, dt: float) -> np.ndarray:
    """Wheel-speed noise (n, 4) [rad/s]: each axle's vibration, partly common, and white noise."""
    c = sensor.axle_noise_correlation
    vib = np.empty((n, 4))
    for axle, (f_hz, amp) in enumerate(
        zip(sensor.wheel_vibration_hz, sensor.wheel_vibration_radps, strict=True)
    ):
        common = _resonance(rng, (n, 1), f_hz, dt)
        own = _resonance(rng, (n, 2), f_hz, dt)
        vib[:, 2 * axle : 2 * axle + 2] = amp * (np.sqrt(c) * common + np.sqrt(1 - c) * own)
    white_sd = np.repeat(np.asarray(sensor.wheel_speed_noise_radps, dtype=float), 2)
    return vib + white_sd[None, :] * rng.standard_normal((n, 4))


def _imu(
    rng: np.random.Generator,
    sensor: SensorModel,
    offsets: SensorTruth,
    accel_mps2: np.ndarray,
    ay_mps2: np.ndarray,
    grade_rad: np.ndarray,
    shake: np.ndarray,
    bump_imu: np.ndarray,
    dt: float,
    pitch_gradient_rad_per_mps2: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The IMU's a_x, a_y, a_z [m/s²]: specific force pitched by mounting and suspension."""
    n = shake.shape[0]
    # Specific force in the sensor frame, pitched by mounting + suspension pitch on a grade.
    pitch = offsets.mounting_pitch_rad + pitch_gradient_rad_per_mps2 * accel_mps2
    body = (
        np.asarray(sensor.accel_vibration_mps2)[None, :]
        * _resonance(rng, (n, 3), sensor.accel_vibration_hz, dt, zeta=0.3)
        + np.asarray(sensor.accel_noise_mps2)[None, :] * rng.standard_normal((n, 3))
    ) * shake + bump_imu
    g = GRAVITY_MPS2
    fx = accel_mps2 + g * np.sin(grade_rad)
    fz = g * np.cos(grade_rad)
    ax = offsets.ax_gain * (fx * np.cos(pitch) + fz * np.sin(pitch)) + offsets.imu_bias_mps2[0]
    ax = ax + body[:, 0]
    ay = ay_mps2 + offsets.imu_bias_mps2[1] + body[:, 1]
    az = -fx * np.sin(pitch) + fz * np.cos(pitch) + body[:, 2]
    return ax, ay, az


def _gnss_speed(
    rng: np.random.Generator,
    sensor: SensorModel,
    time_s: np.ndarray,
    speed_mps: np.ndarray,
    duration: float,
) -> np.ndarray:
    """The GNSS speed at the logged times [m/s]: noisy fixes, held or interpolated."""
    fix_t = np.arange(0.0, duration + 1e-9, 1.0 / sensor.gnss_rate_hz) + time_s[0]
    fix_v = np.interp(fix_t, time_s, speed_mps) + sensor.gnss_noise_mps * rng.standard_normal(
        len(fix_t)
    )
    if sensor.gnss_hold:
        # Zero-order hold: each sample sees the most recent fix.
        idx = np.clip(np.searchsorted(fix_t, time_s, side="right") - 1, 0, len(fix_t) - 1)
        ref = fix_v[idx]
    else:
        ref = np.interp(time_s, fix_t, fix_v)
    return np.maximum(ref, 0.0)


def _drop(
    rng: np.random.Generator,
    sensor: SensorModel,
    columns: dict[str, np.ndarray],
    dt: float,
    duration: float,
) -> None:
    """Set dropped samples to NaN in place (never the time column)."""
    n = len(columns["time"])
    names = [k for k in columns if k != "time"]
    if sensor.drop_probability > 0:
        for k in names:
            columns[k][rng.random(n) < sensor.drop_probability] = np.nan
    n_bursts = rng.poisson(sensor.dropout_bursts_per_hour * duration / 3600.0)
    for _ in range(n_bursts):
        i0 = int(rng.integers(0, n))
        i1 = min(n, i0 + max(1, int(rng.uniform(0.05, 0.5) / dt)))
        for k in names:
            columns[k][i0:i1] = np.nan
