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

import dataclasses

import equinox as eqx
import numpy as np
import pandas as pd
from scipy.signal import lfilter

from ..physics.vehicle import GRAVITY_MPS2
from .profiles import ou_process

WHEELS: tuple[str, str, str, str] = ("fl", "fr", "rl", "rr")


def _nonneg(owner: str, **values: float) -> None:
    for name, value in values.items():
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"{owner}.{name}: expected a finite value >= 0, got {value!r}")


class SensorModel(eqx.Module):
    """Noise, quantisation, offsets and dropouts of the logged channels (per drive).

    Offsets (IMU bias, mounting pitch, wheel-radius errors) are drawn per drive from
    N(mean, sd); set an sd to 0 to fix a value exactly.

    Parameters
    ----------
    timing_jitter : float
        Sample-time jitter as a fraction of the nominal interval (uniform ±, < 0.5 keeps time
        strictly increasing) [-].
    wheel_speed_resolution_kmh : float
        CAN wheel-speed resolution [km/h] (0 = no quantisation); logged wheel speeds are the CAN
        value divided by the nominal radius, so the step is this / 3.6 / R_nominal [rad/s].
    wheel_speed_noise_radps : tuple of float
        White noise sd of the wheel speeds (front, rear) [rad/s].
    wheel_vibration_radps : tuple of float
        Sd of the resonant wheel-speed vibration (front, rear) [rad/s].
    wheel_vibration_hz : tuple of float
        Resonance frequencies (front, rear) [Hz] (real RAV4 log: broad ~8 Hz front, 12.5 Hz rear).
    axle_noise_correlation : float
        Share of the vibration variance common to both wheels of an axle [-].
    roughness_log_sd : float
        Log-sd of the slowly varying road-roughness factor on wheel and IMU noise [-].
    radius_error_mean : tuple of 4 float
        Mean relative rolling-radius error per wheel (fl, fr, rl, rr) [-].
    radius_error_sd : float
        Sd of the relative per-wheel rolling-radius error [-] (fractions of a percent).
    accel_noise_mps2 : tuple of 3 float
        White noise sd of (ax, ay, az) [m/s²].
    accel_vibration_mps2 : tuple of 3 float
        Sd of the resonant vehicle vibration on (ax, ay, az) [m/s²].
    accel_vibration_hz : float
        Its frequency [Hz] (the real log: 10-15 Hz on ax and az, the rear wheels' mode).
    ax_gain, ax_gain_sd : float
        Scale factor of the logged ax [-] (the real dashcam reads 0.79 of the acceleration), and
        its relative spread from drive to drive (accelerometer scale-factor error, ~1 %).
    imu_bias_mean_mps2, imu_bias_sd_mps2 : float
        Accelerometer bias of ax and ay [m/s²].
    mounting_pitch_mean_rad, mounting_pitch_sd_rad : float
        IMU mounting pitch (nose-up positive) [rad].
    yaw_rate_noise_radps, yaw_rate_bias_sd_radps : float
        Gyro noise and bias [rad/s].
    steering_resolution_rad, steering_noise_rad : float
        Steering-wheel angle quantisation step and noise [rad].
    gnss_rate_hz : float
        GNSS speed rate (0 = no ``speed_reference`` column) [Hz]; held between fixes.
    gnss_noise_mps : float
        GNSS speed noise [m/s].
    gnss_hold : bool
        Hold each fix until the next (True) or interpolate linearly between fixes (False, as the
        comma2k19 processing did).
    drop_probability : float
        Probability that one channel's sample is NaN [-].
    dropout_bursts_per_hour : float
        Rate of whole-bus dropouts (all channels NaN for 0.05–0.5 s) [1/h].
    ambient_resolution_c : float
        Resolution of the ambient-temperature channel [°C].
    bumps_per_km : float
        Road bumps (joints, potholes) per km: each shakes the front wheels, then the rear ones a
        wheelbase later, and the IMU — the heavy tails of the real log (kurtosis ~100 of its
        high-passed wheel speeds) [1/km].
    bump_amplitude_radps : float
        Median peak front-wheel disturbance of a bump (log-normal, log-sd 1.0, capped at 6× the
        median) [rad/s]; the rear wheels see 1.5 times it, the IMU about 1.2 (ax), 0.5 (ay) and
        1.5 (az) m/s² per rad/s.
    """

    timing_jitter: float = 0.25
    wheel_speed_resolution_kmh: float = 0.01
    wheel_speed_noise_radps: tuple[float, float] = eqx.field(static=True, default=(0.07, 0.015))
    wheel_vibration_radps: tuple[float, float] = eqx.field(static=True, default=(0.07, 0.16))
    wheel_vibration_hz: tuple[float, float] = eqx.field(static=True, default=(8.0, 12.5))
    axle_noise_correlation: float = 0.5
    roughness_log_sd: float = 0.35
    radius_error_mean: tuple[float, float, float, float] = eqx.field(
        static=True, default=(0.0, 0.0, 0.0, 0.0)
    )
    radius_error_sd: float = 0.002
    accel_noise_mps2: tuple[float, float, float] = eqx.field(
        static=True, default=(0.25, 0.12, 0.17)
    )
    accel_vibration_mps2: tuple[float, float, float] = eqx.field(
        static=True, default=(0.28, 0.3, 0.38)
    )
    accel_vibration_hz: float = 12.0
    ax_gain: float = 1.0
    ax_gain_sd: float = 0.01
    imu_bias_mean_mps2: float = 0.0
    imu_bias_sd_mps2: float = 0.05
    mounting_pitch_mean_rad: float = 0.0
    mounting_pitch_sd_rad: float = 0.02
    yaw_rate_noise_radps: float = 0.0015
    yaw_rate_bias_sd_radps: float = 0.001
    steering_resolution_rad: float = float(np.deg2rad(0.1))
    steering_noise_rad: float = 0.0002
    gnss_rate_hz: float = 20.0
    gnss_noise_mps: float = 0.02
    gnss_hold: bool = eqx.field(static=True, default=True)
    drop_probability: float = 0.001
    dropout_bursts_per_hour: float = 6.0
    ambient_resolution_c: float = 0.5
    bumps_per_km: float = 4.0
    bump_amplitude_radps: float = 0.6

    def __check_init__(self):
        _nonneg(
            "SensorModel",
            **{
                k: getattr(self, k)
                for k in (
                    "wheel_speed_resolution_kmh",
                    "roughness_log_sd",
                    "radius_error_sd",
                    "accel_vibration_hz",
                    "ax_gain",
                    "ax_gain_sd",
                    "imu_bias_sd_mps2",
                    "mounting_pitch_sd_rad",
                    "yaw_rate_noise_radps",
                    "yaw_rate_bias_sd_radps",
                    "steering_resolution_rad",
                    "steering_noise_rad",
                    "gnss_rate_hz",
                    "gnss_noise_mps",
                    "dropout_bursts_per_hour",
                    "ambient_resolution_c",
                    "bumps_per_km",
                    "bump_amplitude_radps",
                )
            },
        )
        if not 0.0 <= self.timing_jitter < 0.5:
            raise ValueError(
                f"SensorModel.timing_jitter: expected a value in [0, 0.5), got {self.timing_jitter}"
            )
        for name in ("axle_noise_correlation", "drop_probability"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"SensorModel.{name}: expected a value in [0, 1], got {value}")
        for name, size in (
            ("wheel_vibration_radps", 2),
            ("wheel_speed_noise_radps", 2),
            ("accel_vibration_mps2", 3),
            ("accel_noise_mps2", 3),
            ("radius_error_mean", 4),
        ):
            value = tuple(getattr(self, name))
            if len(value) != size or not all(np.isfinite(v) for v in value):
                raise ValueError(f"SensorModel.{name}: expected {size} finite values, got {value}")
        if (
            min(self.wheel_vibration_radps) < 0
            or min(self.wheel_speed_noise_radps) < 0
            or min(self.accel_vibration_mps2) < 0
            or min(self.accel_noise_mps2) < 0
        ):
            raise ValueError(
                "SensorModel: expected vibration amplitudes >= 0, got "
                f"{self.wheel_vibration_radps}, {self.accel_vibration_mps2}"
            )
        if len(self.wheel_vibration_hz) != 2 or min(self.wheel_vibration_hz) <= 0:
            raise ValueError(
                "SensorModel.wheel_vibration_hz: expected (front_hz, rear_hz) > 0, got "
                f"{self.wheel_vibration_hz}"
            )

    @classmethod
    def ideal(cls) -> SensorModel:
        """No noise, quantisation, offsets, jitter or dropouts (for checking the physics)."""
        zero: dict = {
            k: 0.0
            for k in (
                "timing_jitter wheel_speed_resolution_kmh "
                "roughness_log_sd radius_error_sd "
                "imu_bias_sd_mps2 mounting_pitch_sd_rad "
                "ax_gain_sd yaw_rate_noise_radps yaw_rate_bias_sd_radps "
                "steering_resolution_rad steering_noise_rad gnss_noise_mps drop_probability "
                "dropout_bursts_per_hour ambient_resolution_c bumps_per_km"
            ).split()
        }
        zero.update(
            wheel_speed_noise_radps=(0.0, 0.0),
            wheel_vibration_radps=(0.0, 0.0),
            accel_vibration_mps2=(0.0, 0.0, 0.0),
            accel_noise_mps2=(0.0, 0.0, 0.0),
        )
        return cls(**zero)

    @classmethod
    def rav4_comma2k19(cls) -> SensorModel:
        """Closest match to the real comma2k19 RAV4 log (use with ``sample_rate_hz=83``).

        Beyond the defaults (which already carry its noise levels and quantisation): irregular
        sample times (CV 0.34), its ax offset of −0.62 m/s² as a −4.6° mounting pitch, ax read at
        0.79 of the acceleration (a gain error of the dashcam IMU found against both GNSS and
        wheel-speed derivatives), per-wheel radii 0.84-1.00 % above the nominal 0.35 m (the log's
        wheels read 0.86 % below GNSS), GNSS interpolated between fixes, no dropped samples.
        Fitted by ``benchmarks/real_vs_sim.py``.
        """
        return cls(
            timing_jitter=0.45,
            mounting_pitch_mean_rad=float(np.deg2rad(-4.6)),
            mounting_pitch_sd_rad=0.0,
            imu_bias_sd_mps2=0.0,
            ax_gain=0.79,
            ax_gain_sd=0.0,
            radius_error_mean=(0.0084, 0.0085, 0.0096, 0.0100),
            radius_error_sd=0.0,
            gnss_hold=False,
            drop_probability=0.0,
            dropout_bursts_per_hour=0.0,
        )


def scale_noise(sensor: SensorModel, factor: float) -> SensorModel:
    """The same sensors with every noise amplitude (white, vibration, bumps, GNSS) times ``factor``.

    Offsets, quantisation, timing and dropouts are unchanged: this is the "noise level" axis of a
    recovery benchmark.

    Examples
    --------
    >>> scale_noise(SensorModel(), 2.0).yaw_rate_noise_radps
    0.003
    """
    if not (np.isfinite(factor) and factor >= 0):
        raise ValueError(f"scale_noise: expected a factor >= 0, got {factor!r}")
    f = float(factor)
    return dataclasses.replace(
        sensor,
        wheel_speed_noise_radps=tuple(f * v for v in sensor.wheel_speed_noise_radps),
        wheel_vibration_radps=tuple(f * v for v in sensor.wheel_vibration_radps),
        accel_noise_mps2=tuple(f * v for v in sensor.accel_noise_mps2),
        accel_vibration_mps2=tuple(f * v for v in sensor.accel_vibration_mps2),
        yaw_rate_noise_radps=f * sensor.yaw_rate_noise_radps,
        steering_noise_rad=f * sensor.steering_noise_rad,
        gnss_noise_mps=f * sensor.gnss_noise_mps,
        bump_amplitude_radps=f * sensor.bump_amplitude_radps,
    )


class SensorTruth(eqx.Module):
    """The per-drive sensor offsets actually drawn (part of the drive's truth).

    Attributes
    ----------
    radius_error : relative per-wheel rolling-radius errors ε (fl, fr, rl, rr);
        R_i = R_nom (1 + ε_i).
    imu_bias_mps2 : accelerometer bias (ax, ay) [m/s²].
    mounting_pitch_rad : IMU mounting pitch [rad], nose-up positive.
    ax_gain : scale factor of the logged ax [-].
    yaw_rate_bias_radps : gyro bias [rad/s].
    wheel_speed_step_radps : quantisation step of the logged wheel speeds [rad/s].
    """

    radius_error: np.ndarray
    imu_bias_mps2: np.ndarray
    mounting_pitch_rad: float
    yaw_rate_bias_radps: float
    wheel_speed_step_radps: float
    ax_gain: float = 1.0


def draw_sensor_truth(
    rng: np.random.Generator, sensor: SensorModel, wheel_radius_m: float
) -> SensorTruth:
    """Draw the per-drive offsets of ``sensor`` (radius errors, IMU bias, pitch and gain)."""
    return SensorTruth(
        radius_error=np.asarray(sensor.radius_error_mean, dtype=float)
        + rng.standard_normal(4) * sensor.radius_error_sd,
        imu_bias_mps2=sensor.imu_bias_mean_mps2 + rng.standard_normal(2) * sensor.imu_bias_sd_mps2,
        mounting_pitch_rad=float(
            sensor.mounting_pitch_mean_rad + rng.standard_normal() * sensor.mounting_pitch_sd_rad
        ),
        yaw_rate_bias_radps=float(rng.standard_normal() * sensor.yaw_rate_bias_sd_radps),
        wheel_speed_step_radps=sensor.wheel_speed_resolution_kmh / 3.6 / wheel_radius_m,
        ax_gain=float(sensor.ax_gain * (1.0 + rng.standard_normal() * sensor.ax_gain_sd)),
    )


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
    rough = (
        np.exp(
            ou_process(rng, n, dt, 10.0, sensor.roughness_log_sd) - 0.5 * sensor.roughness_log_sd**2
        )
        if sensor.roughness_log_sd > 0
        else np.ones(n)
    )

    # Wheel speeds: vibration partly common to an axle, plus white noise, then CAN quantisation
    # (the CAN value is a speed; the logger divides by the nominal radius).
    c = sensor.axle_noise_correlation
    vib = np.empty((n, 4))
    for axle, (f_hz, amp) in enumerate(
        zip(sensor.wheel_vibration_hz, sensor.wheel_vibration_radps, strict=True)
    ):
        common = _resonance(rng, (n, 1), f_hz, dt)
        own = _resonance(rng, (n, 2), f_hz, dt)
        vib[:, 2 * axle : 2 * axle + 2] = amp * (np.sqrt(c) * common + np.sqrt(1 - c) * own)
    white_sd = np.repeat(np.asarray(sensor.wheel_speed_noise_radps, dtype=float), 2)
    wheel_noise = vib + white_sd[None, :] * rng.standard_normal((n, 4))
    bump_wheels, bump_imu = _bumps(rng, sensor, np.asarray(speed_mps, dtype=float), dt, wheelbase_m)
    # Road-induced speed fluctuations vanish at standstill (and a wheel-speed sensor reports a
    # magnitude, never a negative speed).
    moving = np.clip(np.asarray(speed_mps) / 5.0, 0.0, 1.0)
    omega = wheel_speed_radps + wheel_noise * (rough * moving)[:, None] + bump_wheels
    omega = np.maximum(_quantise(omega, offsets.wheel_speed_step_radps), 0.0)

    # IMU: specific force in the sensor frame, pitched by mounting + suspension pitch on a grade.
    pitch = offsets.mounting_pitch_rad + pitch_gradient_rad_per_mps2 * accel_mps2
    # Vehicle vibration (one mode, three axes) and white noise, both scaled by road roughness and
    # fading out at standstill like the wheel noise.
    shake = (rough * np.maximum(moving, 0.2))[:, None]
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
        columns["speed_reference"] = np.maximum(ref, 0.0)

    _drop(rng, sensor, columns, dt, duration)
    return pd.DataFrame(columns)


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
