"""The simulated sensors' properties: noise, quantisation, offsets and dropouts
(:class:`SensorModel`), and the fixed errors one car's sensors have (:class:`SensorTruth`).

:func:`~tyrebayes.simulate.sensors.measure` applies them; re-exported by
:mod:`tyrebayes.simulate.sensors`.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import numpy as np

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
