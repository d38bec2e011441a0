"""A baseline lateral estimator in the style of openpilot's ``paramsd`` (issue 54, item 3).

openpilot (``commaai/openpilot``: ``selfdrive/locationd/paramsd.py`` and
``selfdrive/locationd/models/car_kf.py``) learns a car's lateral parameters online with an extended
Kalman filter over a single-track (bicycle) model: one *stiffness factor* ``x`` that multiplies
nominal front and rear cornering stiffnesses (the same factor on both axles), the steering ratio
and a steering-angle offset, with hand-tuned noises. This module is that filter, reduced to the
states a stream in the package's contract can drive, so that tyrebayes' lateral inference has the
widely used estimator beside it on the same drives.

States ``[v_y, r, x, sr, offset]``: lateral velocity at the centre of gravity [m/s], yaw rate
[rad/s], stiffness factor [-], steering ratio [-] and steering-wheel-angle offset [rad]. Dynamics
(car_kf.py, after Guiggiani, *The Science of Vehicle Dynamics*, eq. 6.15 with 6.198), driven by the
measured speed u and steering-wheel angle s, with C_f = x·C_f0, C_r = x·C_r0 [N/rad] and the
road-wheel angle δ = (s − offset)/sr::

    v̇_y = −(C_f + C_r)/(m u) v_y − ((C_f l_f − C_r l_r)/(m u) + u) r + C_f/m δ
    ṙ   = −(C_f l_f − C_r l_r)/(J u) v_y − (C_f l_f² + C_r l_r²)/(J u) r + C_f l_f/J δ

integrated with one Euler step per sample (``f = state + dt·state_dot``, the previous sample's speed
and angle held over the step) and propagated as rednose's ``EKF_sym`` does: P ← F P Fᵀ + dt·Q (Q is
a rate, per second). Observations: the yaw rate at openpilot's pose rate (20 Hz), and after each,
paramsd's pseudo-observations of the filter's own stiffness factor (sd 0.5) and steering ratio
(sd 5), which bound their sd on long straight stretches (and with it slow the learning): with the
factor's process noise (0.0005/√s) they hold its stated sd near √(0.05 s · 0.0005²/s · 0.5²) ≈
0.0075 whatever the data say, and from openpilot's ``P_initial = Q`` the factor of a fresh car
moves by hundredths in ten minutes (openpilot keeps the learned state between drives). openpilot
does not observe a_y; ``ParamsdConfig(use_ay=True)`` adds it (h = (C_f α_f + C_r α_r)/m) for
comparison.

Nominal cornering stiffnesses, as openpilot derives them for a car without measured ones
(``selfdrive/car/__init__.py: scale_tire_stiffness``): the Honda Civic's measured axle stiffnesses
scaled by mass and by the static load share of each axle,

    C_f0 = 192150 N/rad · k · (m / 1462 kg) · (l_r / L) / (1.62 / 2.70)
    C_r0 = 202500 N/rad · k · (m / 1462 kg) · (l_f / L) / (1.08 / 2.70)

(reference car: m = 1326 kg + 136 kg standard cargo, L = 2.70 m, l_f = 0.4 L; k is the per-car
``tireStiffnessFactor``, 1.0 unless a port sets it). Normalised by the static axle load these are
the same for every car: c_y0,front = 192150/(1462·0.6·g) = 22.3 /rad and c_y0,rear =
202500/(1462·0.4·g) = 35.3 /rad, so the filter's c_y_front, c_y_rear are 22.3·x and 35.3·x: their
ratio is fixed at 1.58 and only the common level is learned.

Left out of openpilot's 9 states: the longitudinal velocity (the measured speed drives the model),
the steering angle as a state (the measured angle is the input), the fast angle offset and the road
roll (no localiser here: bank enters the filter as model error, as it does when openpilot's roll is
invalid). The yaw inertia is the vehicle file's, not openpilot's ``scale_rot_inertia``. Gates follow
paramsd: the filter runs only while the speed exceeds ``min_speed_mps`` (5 m/s, older paramsd's
threshold; today's uses 1 m/s) and the steering-wheel angle is within 45° (the linear region), and
its clock is held while it does not (no prediction, so P does not grow while stopped); a yaw rate
beyond 1 rad/s is replaced by 0 with sd 10°/s; a non-finite state resets the filter.

Usage: ``python -m benchmarks.paramsd_ekf [DIR] [--out FILE] [--drives l00,l01] [--use-ay]`` runs
the filter on the external cornering drives (``../shared/data/external_lateral`` by default) and
prints per-drive estimates against ``truth.json``.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from _data import Drive

GRAVITY_MPS2 = 9.80665

# openpilot's reference car for tyre stiffness (selfdrive/car/__init__.py, VehicleDynamicsParams:
# a 2016 Honda Civic Touring with 136 kg standard cargo).
_REF_MASS_KG = 1326.0 + 136.0
_REF_WHEELBASE_M = 2.70
_REF_CENTER_TO_FRONT_M = 0.4 * _REF_WHEELBASE_M
_REF_CENTER_TO_REAR_M = _REF_WHEELBASE_M - _REF_CENTER_TO_FRONT_M
_REF_STIFFNESS_FRONT_N_PER_RAD = 192150.0
_REF_STIFFNESS_REAR_N_PER_RAD = 202500.0

# State indices.
VY, R, X, SR, OFF = range(5)
STATE_NAMES = ("lateral_velocity", "yaw_rate", "stiffness_factor", "steer_ratio", "angle_offset")

# locationd's pose filter: gyro observation sd 0.025 rad/s at 100 Hz and angular-velocity process
# noise 0.1 rad/s per √s; its steady-state sd of the yaw rate, which paramsd passes on as the yaw
# rate's observation sd, is (Q·R·dt)^(1/4) = (0.1²·0.025²·0.01)^(1/4) ≈ 0.0158 rad/s.
_LOCATIOND_YAW_RATE_SD = (0.1**2 * 0.025**2 * 0.01) ** 0.25


@dataclass(frozen=True)
class ParamsdConfig:
    """The filter's hand-set numbers; defaults are openpilot's (car_kf.py, paramsd.py).

    Process noises are rates (variance per second, rednose adds dt·Q). The initial covariance is
    openpilot's ``P_initial = Q`` (a car with no saved parameters); its initial state is factor 1,
    the vehicle file's steering ratio and zero offset.
    """

    q_lateral_velocity: float = 0.01**2
    q_yaw_rate: float = math.radians(0.1) ** 2
    q_stiffness: float = (0.05 / 100) ** 2
    q_steer_ratio: float = 0.01**2
    q_angle_offset: float = math.radians(0.02) ** 2
    initial_sd_stiffness: float = 0.05 / 100
    initial_sd_steer_ratio: float = 0.01
    initial_sd_angle_offset: float = math.radians(0.02)
    initial_stiffness: float = 1.0
    initial_angle_offset: float = 0.0
    # Pseudo-observations of the current stiffness and steering ratio (paramsd: "to bound the
    # respective estimate STD").
    pseudo_sd_stiffness: float = 0.5
    pseudo_sd_steer_ratio: float = 5.0
    yaw_rate_sd: float = _LOCATIOND_YAW_RATE_SD
    observation_rate_hz: float = 20.0  # livePose, DT_MDL = 0.05 s
    use_ay: bool = False
    ay_sd: float = 0.5  # locationd's accelerometer observation sd [m/s²]
    min_speed_mps: float = 5.0
    max_steering_wheel_angle_rad: float = math.radians(45.0)
    max_yaw_rate_rps: float = 1.0
    invalid_yaw_rate_sd: float = math.radians(10.0)
    tire_stiffness_factor: float = 1.0
    # paramsd's validity ranges for its outputs.
    stiffness_valid_range: tuple[float, float] = (0.2, 5.0)
    steer_ratio_valid_fraction: tuple[float, float] = (0.5, 2.0)
    max_angle_offset_rad: float = math.radians(10.0)

    def __post_init__(self):
        for name in (
            "q_lateral_velocity",
            "q_yaw_rate",
            "q_stiffness",
            "q_steer_ratio",
            "q_angle_offset",
            "initial_sd_stiffness",
            "initial_sd_steer_ratio",
            "initial_sd_angle_offset",
            "initial_stiffness",
            "pseudo_sd_stiffness",
            "pseudo_sd_steer_ratio",
            "yaw_rate_sd",
            "observation_rate_hz",
            "ay_sd",
            "min_speed_mps",
            "max_steering_wheel_angle_rad",
            "max_yaw_rate_rps",
            "invalid_yaw_rate_sd",
            "tire_stiffness_factor",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"ParamsdConfig.{name}: expected a finite value > 0, got {value}")


def nominal_cornering_stiffness(
    mass_kg: float, wheelbase_m: float, l_f_m: float, tire_stiffness_factor: float = 1.0
) -> tuple[float, float]:
    """openpilot's nominal axle cornering stiffnesses ``(C_f0, C_r0)`` [N/rad].

    ``scale_tire_stiffness``: the reference Civic's stiffness times the mass ratio and the axle's
    static load share relative to the Civic's (module docstring).

    >>> cf, cr = nominal_cornering_stiffness(1462.0, 2.70, 1.08)
    >>> round(cf), round(cr)
    (192150, 202500)
    """
    l_r = wheelbase_m - l_f_m
    mass_ratio = mass_kg / _REF_MASS_KG
    cf = (
        _REF_STIFFNESS_FRONT_N_PER_RAD
        * tire_stiffness_factor
        * mass_ratio
        * (l_r / wheelbase_m)
        / (_REF_CENTER_TO_REAR_M / _REF_WHEELBASE_M)
    )
    cr = (
        _REF_STIFFNESS_REAR_N_PER_RAD
        * tire_stiffness_factor
        * mass_ratio
        * (l_f_m / wheelbase_m)
        / (_REF_CENTER_TO_FRONT_M / _REF_WHEELBASE_M)
    )
    return cf, cr


def _summary(mean: float, sd: float, lo2: float, hi2: float, lo90: float, hi90: float) -> dict:
    return {
        "mean": float(mean),
        "sd": float(sd),
        "hdi_90": [float(lo90), float(hi90)],
        "bounds_2sd": [float(lo2), float(hi2)],
    }


@dataclass(frozen=True)
class ParamsdResult:
    """The filter's trajectories (one row per input sample) and its final estimates.

    Per-sample arrays (length n): ``time``, ``active`` (the filter ran at this sample),
    ``stiffness_factor``/``_sd``, ``steer_ratio``/``_sd``, ``angle_offset``/``_sd`` [rad],
    ``lateral_velocity`` [m/s], ``yaw_rate_estimate`` [rad/s], ``valid`` (paramsd's output
    validity: factor in 0.2-5, ratio within 0.5-2 × nominal, |offset| < 10°) and
    ``sensor_valid`` (paramsd's check |u (r̂ − r)| < 4 m/s² above 10 m/s).

    Final figures are the last sample's state (what paramsd would publish and save), with the
    sd from the filter's covariance. Derived: ``c_y_front`` = x C_f0 /(m g l_r / L) and
    ``c_y_rear`` = x C_r0 /(m g l_f / L) [1/rad] (cornering stiffness over static axle load), and
    the understeer gradient K = (m/L)(l_r/C_f − l_f/C_r) = K_0 / x [rad/(m/s²)], with K_0 the
    nominal (x = 1) gradient. Bounds (±2σ, and the 90 % interval ±1.645σ) of the derived figures
    are the stiffness factor's mapped through them (monotone in x); K's sd is the delta method's.
    """

    time: np.ndarray
    active: np.ndarray
    stiffness_factor: np.ndarray
    stiffness_factor_sd: np.ndarray
    steer_ratio: np.ndarray
    steer_ratio_sd: np.ndarray
    angle_offset: np.ndarray
    angle_offset_sd: np.ndarray
    lateral_velocity: np.ndarray
    yaw_rate_estimate: np.ndarray
    valid: np.ndarray
    sensor_valid: np.ndarray
    final_stiffness_factor: float
    final_stiffness_factor_sd: float
    final_steer_ratio: float
    final_steer_ratio_sd: float
    final_angle_offset: float
    final_angle_offset_sd: float
    nominal_stiffness_front_n_per_rad: float
    nominal_stiffness_rear_n_per_rad: float
    nominal_c_y_front: float
    nominal_c_y_rear: float
    nominal_understeer_gradient: float
    n_resets: int
    seconds: float
    config: ParamsdConfig = field(repr=False)

    def _factor_bounds(self, z: float) -> tuple[float, float]:
        x, s = self.final_stiffness_factor, self.final_stiffness_factor_sd
        return x - z * s, x + z * s

    def _linear_in_x(self, scale: float) -> dict:
        x, s = self.final_stiffness_factor, self.final_stiffness_factor_sd
        lo2, hi2 = self._factor_bounds(2.0)
        lo90, hi90 = self._factor_bounds(1.645)
        return _summary(scale * x, scale * s, scale * lo2, scale * hi2, scale * lo90, scale * hi90)

    @property
    def c_y_front(self) -> dict:
        """Front axle cornering stiffness over its static load [1/rad]: mean, sd, bounds."""
        return self._linear_in_x(self.nominal_c_y_front)

    @property
    def c_y_rear(self) -> dict:
        """Rear axle cornering stiffness over its static load [1/rad]: mean, sd, bounds."""
        return self._linear_in_x(self.nominal_c_y_rear)

    @property
    def understeer_gradient(self) -> dict:
        """K = K_0/x [rad/(m/s²)]: mean, delta-method sd, bounds from x's (inf past x = 0)."""
        k0 = self.nominal_understeer_gradient
        x, s = self.final_stiffness_factor, self.final_stiffness_factor_sd

        def mapped(lo: float, hi: float) -> tuple[float, float]:
            a = k0 / hi if hi > 0 else math.copysign(math.inf, k0)
            b = k0 / lo if lo > 0 else math.copysign(math.inf, k0)
            return (min(a, b), max(a, b))

        lo2, hi2 = mapped(*self._factor_bounds(2.0))
        lo90, hi90 = mapped(*self._factor_bounds(1.645))
        return _summary(k0 / x, abs(k0) * s / x**2, lo2, hi2, lo90, hi90)

    @property
    def steering_ratio(self) -> dict:
        """The learned steering ratio [-]: mean, sd, bounds."""
        m, s = self.final_steer_ratio, self.final_steer_ratio_sd
        return _summary(m, s, m - 2 * s, m + 2 * s, m - 1.645 * s, m + 1.645 * s)

    @property
    def angle_offset_rad(self) -> dict:
        """The learned steering-wheel-angle offset [rad]: mean, sd, bounds."""
        m, s = self.final_angle_offset, self.final_angle_offset_sd
        return _summary(m, s, m - 2 * s, m + 2 * s, m - 1.645 * s, m + 1.645 * s)

    def stability(self, last_fraction: float = 0.5) -> dict:
        """Spread of the stiffness factor's trajectory over the last part of the drive (by time)."""
        t = self.time
        keep = t >= t[0] + (1.0 - last_fraction) * (t[-1] - t[0])
        x = self.stiffness_factor[keep]
        sr = self.steer_ratio[keep]
        return {
            "last_fraction": last_fraction,
            "stiffness_factor_std": float(np.std(x)),
            "stiffness_factor_min": float(np.min(x)),
            "stiffness_factor_max": float(np.max(x)),
            "steer_ratio_std": float(np.std(sr)),
            "steer_ratio_min": float(np.min(sr)),
            "steer_ratio_max": float(np.max(sr)),
        }

    def to_dict(self, trajectories: bool = False) -> dict[str, Any]:
        """JSON-ready summary; ``trajectories=True`` adds the per-sample arrays as lists."""
        out: dict[str, Any] = {
            "stiffness_factor": {
                "mean": self.final_stiffness_factor,
                "sd": self.final_stiffness_factor_sd,
            },
            "steering_ratio": self.steering_ratio,
            "angle_offset_rad": self.angle_offset_rad,
            "c_y_front": self.c_y_front,
            "c_y_rear": self.c_y_rear,
            "understeer_gradient": self.understeer_gradient,
            "nominal": {
                "stiffness_front_n_per_rad": self.nominal_stiffness_front_n_per_rad,
                "stiffness_rear_n_per_rad": self.nominal_stiffness_rear_n_per_rad,
                "c_y_front": self.nominal_c_y_front,
                "c_y_rear": self.nominal_c_y_rear,
                "understeer_gradient": self.nominal_understeer_gradient,
            },
            "active_fraction": float(np.mean(self.active)),
            "valid_fraction": float(np.mean(self.valid[self.active])) if self.active.any() else 0.0,
            "sensor_valid_fraction": (
                float(np.mean(self.sensor_valid[self.active])) if self.active.any() else 0.0
            ),
            "n_resets": self.n_resets,
            "stability": self.stability(),
            "seconds": self.seconds,
            "config": {
                k: (list(v) if isinstance(v, tuple) else v) for k, v in self.config.__dict__.items()
            },
        }
        if trajectories:
            for name in (
                "time",
                "active",
                "stiffness_factor",
                "stiffness_factor_sd",
                "steer_ratio",
                "steer_ratio_sd",
                "angle_offset",
                "angle_offset_sd",
                "lateral_velocity",
                "yaw_rate_estimate",
                "valid",
                "sensor_valid",
            ):
                out[name] = getattr(self, name).tolist()
        return out


def _as_1d(name: str, values, n: int | None) -> np.ndarray:
    a = np.asarray(values, dtype=np.float64)
    if a.ndim != 1:
        raise ValueError(f"run_paramsd: {name} expected a 1-d array, got shape {a.shape}")
    if n is not None and a.shape[0] != n:
        raise ValueError(f"run_paramsd: {name} expected length {n}, got {a.shape[0]}")
    return a


def run_paramsd(
    time,
    speed,
    yaw_rate,
    steering_wheel_angle,
    vehicle,
    *,
    lateral_acceleration=None,
    config: ParamsdConfig | None = None,
) -> ParamsdResult:
    """Run the paramsd-style EKF over one drive.

    Parameters
    ----------
    time : array (n,)
        Sample times [s], strictly increasing.
    speed : array (n,)
        Longitudinal speed v_x [m/s] (e.g. the undriven axle's wheel speeds × radius).
    yaw_rate : array (n,)
        Measured yaw rate [rad/s], positive to the left.
    steering_wheel_angle : array (n,)
        Steering-wheel angle [rad], positive to the left.
    vehicle : tyrebayes.physics.vehicle.Vehicle
        Mass, wheelbase, l_f, yaw inertia and nominal steering ratio are used.
    lateral_acceleration : array (n,), optional
        Measured a_y [m/s²]; observed only with ``config.use_ay``.
    config : ParamsdConfig, optional
        Noises and gates; openpilot's by default.

    Returns
    -------
    ParamsdResult
    """
    cfg = config if config is not None else ParamsdConfig()
    t = _as_1d("time", time, None)
    n = t.shape[0]
    if n < 2:
        raise ValueError(f"run_paramsd: time expected at least 2 samples, got {n}")
    if not np.all(np.diff(t) > 0):
        raise ValueError("run_paramsd: time expected strictly increasing")
    u_all = _as_1d("speed", speed, n)
    r_all = _as_1d("yaw_rate", yaw_rate, n)
    sa_all = _as_1d("steering_wheel_angle", steering_wheel_angle, n)
    if cfg.use_ay:
        if lateral_acceleration is None:
            raise ValueError("run_paramsd: config.use_ay needs lateral_acceleration")
        ay_all = _as_1d("lateral_acceleration", lateral_acceleration, n)
    else:
        ay_all = np.zeros(n)

    m = float(vehicle.mass_kg)
    wheelbase = float(vehicle.wheelbase_m)
    a = float(vehicle.cog_to_front_axle_m)
    b = wheelbase - a
    j = float(vehicle.yaw_inertia_kgm2)
    sr_nominal = float(vehicle.steering_ratio)
    cf0, cr0 = nominal_cornering_stiffness(m, wheelbase, a, cfg.tire_stiffness_factor)
    c_y_front0 = cf0 / (m * GRAVITY_MPS2 * b / wheelbase)
    c_y_rear0 = cr0 / (m * GRAVITY_MPS2 * a / wheelbase)
    k0 = (m / wheelbase) * (b / cf0 - a / cr0)

    q = np.diag(
        [
            cfg.q_lateral_velocity,
            cfg.q_yaw_rate,
            cfg.q_stiffness,
            cfg.q_steer_ratio,
            cfg.q_angle_offset,
        ]
    )
    x_init = np.array([0.0, 0.0, cfg.initial_stiffness, sr_nominal, cfg.initial_angle_offset])
    p_init = np.diag(
        [
            cfg.q_lateral_velocity,
            cfg.q_yaw_rate,
            cfg.initial_sd_stiffness**2,
            cfg.initial_sd_steer_ratio**2,
            cfg.initial_sd_angle_offset**2,
        ]
    )
    sr_lo = cfg.steer_ratio_valid_fraction[0] * sr_nominal
    sr_hi = cfg.steer_ratio_valid_fraction[1] * sr_nominal
    eye = np.eye(5)
    r_var_yaw = cfg.yaw_rate_sd**2
    r_var_invalid = cfg.invalid_yaw_rate_sd**2
    r_var_ay = cfg.ay_sd**2
    r_var_x = cfg.pseudo_sd_stiffness**2
    r_var_sr = cfg.pseudo_sd_steer_ratio**2
    obs_dt = 1.0 / cfg.observation_rate_hz

    def scalar_update(s, p, h_row, innovation, r_var):
        # Joseph form, as rednose's _update_python.
        ph = p @ h_row
        gain = ph / (h_row @ ph + r_var)
        s = s + gain * innovation
        ikh = eye - np.outer(gain, h_row)
        p = ikh @ p @ ikh.T + r_var * np.outer(gain, gain)
        return s, p

    out = np.empty((n, 5))
    out_var = np.empty((n, 5))
    active = np.zeros(n, dtype=bool)
    valid = np.zeros(n, dtype=bool)
    sensor_valid = np.ones(n, dtype=bool)
    h_yaw = np.array([0.0, 1.0, 0.0, 0.0, 0.0])
    h_x = np.array([0.0, 0.0, 1.0, 0.0, 0.0])
    h_sr = np.array([0.0, 0.0, 0.0, 1.0, 0.0])
    n_resets = 0
    started = _time.perf_counter()

    s = x_init.copy()
    p = p_init.copy()
    filter_time = t[0]
    next_obs = t[0]
    for i in range(n):
        ti, u, r_meas, sa = t[i], u_all[i], r_all[i], sa_all[i]
        is_active = (
            math.isfinite(u)
            and math.isfinite(sa)
            and u > cfg.min_speed_mps
            and abs(sa) < cfg.max_steering_wheel_angle_rad
        )
        if is_active:
            dt = ti - filter_time
            # The inputs held over (t_{i-1}, t_i] are the previous sample's (zero-order hold; in
            # car_kf the steering angle is a state, observed before the next prediction).
            if i > 0 and math.isfinite(u_all[i - 1]) and math.isfinite(sa_all[i - 1]):
                u_in, sa_in = max(u_all[i - 1], cfg.min_speed_mps), sa_all[i - 1]
            else:
                u_in, sa_in = u, sa
            vy, r, x, sr, off = s
            cf, cr = x * cf0, x * cr0
            delta = (sa_in - off) / sr
            a11 = -(cf + cr) / (m * u_in)
            a12 = -(cf * a - cr * b) / (m * u_in) - u_in
            a21 = -(cf * a - cr * b) / (j * u_in)
            a22 = -(cf * a * a + cr * b * b) / (j * u_in)
            vy_dot = a11 * vy + a12 * r + cf / m * delta
            r_dot = a21 * vy + a22 * r + cf * a / j * delta
            # The Jacobian of state_dot is zero outside its first two rows (G), so
            # F P Fᵀ = P1 + dt P1 Gᵀ (in columns 0, 1) with P1 = P + dt G P (in rows 0, 1).
            g = np.array(
                [
                    [
                        a11,
                        a12,
                        # d/dx: the stiffnesses scale with x.
                        -(cf0 + cr0) / (m * u_in) * vy
                        - (cf0 * a - cr0 * b) / (m * u_in) * r
                        + cf0 / m * delta,
                        -cf / m * delta / sr,
                        -cf / (m * sr),
                    ],
                    [
                        a21,
                        a22,
                        -(cf0 * a - cr0 * b) / (j * u_in) * vy
                        - (cf0 * a * a + cr0 * b * b) / (j * u_in) * r
                        + cf0 * a / j * delta,
                        -cf * a / j * delta / sr,
                        -cf * a / (j * sr),
                    ],
                ]
            )
            s = s + dt * np.array([vy_dot, r_dot, 0.0, 0.0, 0.0])
            p = p.copy()
            p[:2] += dt * (g @ p)
            p[:, :2] += dt * (p @ g.T)
            p += dt * q
            filter_time = ti

            if ti >= next_obs - 1e-9:
                next_obs = max(next_obs + obs_dt, ti + 0.5 * obs_dt)
                if math.isfinite(r_meas) and abs(r_meas) < cfg.max_yaw_rate_rps:
                    z, rv = r_meas, r_var_yaw
                else:
                    z, rv = 0.0, r_var_invalid
                s, p = scalar_update(s, p, h_yaw, z - s[R], rv)
                if cfg.use_ay and math.isfinite(ay_all[i]):
                    vy, r, x, sr, off = s
                    delta = (sa - off) / sr
                    alpha_f = delta - (vy + a * r) / u
                    alpha_r = -(vy - b * r) / u
                    h_ay = np.array(
                        [
                            -(x * cf0 + x * cr0) / (m * u),
                            (-x * cf0 * a + x * cr0 * b) / (m * u),
                            (cf0 * alpha_f + cr0 * alpha_r) / m,
                            -x * cf0 * delta / (sr * m),
                            -x * cf0 / (sr * m),
                        ]
                    )
                    pred = x * (cf0 * alpha_f + cr0 * alpha_r) / m
                    s, p = scalar_update(s, p, h_ay, ay_all[i] - pred, r_var_ay)
                s, p = scalar_update(s, p, h_x, 0.0, r_var_x)
                s, p = scalar_update(s, p, h_sr, 0.0, r_var_sr)
                if u > 10.0 and math.isfinite(r_meas):
                    sensor_valid[i] = abs(u * (s[R] - r_meas)) < 4.0
        else:
            # paramsd: "Reset time when stopped so uncertainty doesn't grow".
            filter_time = ti
            next_obs = ti
        if not math.isfinite(float(s.sum() + p.sum())):
            s, p = x_init.copy(), p_init.copy()
            n_resets += 1
        active[i] = is_active
        out[i] = s
        out_var[i] = p.diagonal()
        valid[i] = (
            cfg.stiffness_valid_range[0] <= s[X] <= cfg.stiffness_valid_range[1]
            and sr_lo <= s[SR] <= sr_hi
            and abs(s[OFF]) < cfg.max_angle_offset_rad
        )
    out_sd = np.sqrt(np.maximum(out_var, 0.0))
    seconds = _time.perf_counter() - started

    return ParamsdResult(
        time=t,
        active=active,
        stiffness_factor=out[:, X].copy(),
        stiffness_factor_sd=out_sd[:, X].copy(),
        steer_ratio=out[:, SR].copy(),
        steer_ratio_sd=out_sd[:, SR].copy(),
        angle_offset=out[:, OFF].copy(),
        angle_offset_sd=out_sd[:, OFF].copy(),
        lateral_velocity=out[:, VY].copy(),
        yaw_rate_estimate=out[:, R].copy(),
        valid=valid,
        sensor_valid=sensor_valid,
        final_stiffness_factor=float(out[-1, X]),
        final_stiffness_factor_sd=float(out_sd[-1, X]),
        final_steer_ratio=float(out[-1, SR]),
        final_steer_ratio_sd=float(out_sd[-1, SR]),
        final_angle_offset=float(out[-1, OFF]),
        final_angle_offset_sd=float(out_sd[-1, OFF]),
        nominal_stiffness_front_n_per_rad=cf0,
        nominal_stiffness_rear_n_per_rad=cr0,
        nominal_c_y_front=c_y_front0,
        nominal_c_y_rear=c_y_rear0,
        nominal_understeer_gradient=k0,
        n_resets=n_resets,
        seconds=seconds,
        config=cfg,
    )


# --- the external cornering drives -------------------------------------------------------------

# Configurations run by ``main``: openpilot's numbers as they are, and the same filter with a
# stiffness factor that starts as unknown as paramsd's own pseudo-observation says (sd 0.5) instead
# of openpilot's P_initial = Q (sd 0.0005, i.e. a car whose factor was already learned).
CONFIGS = {
    "openpilot": ParamsdConfig(),
    "wide_prior": ParamsdConfig(initial_sd_stiffness=0.5),
}


def drive_speed(stream, vehicle) -> np.ndarray:
    """v_x from the undriven axle: mean rear wheel speed × radius, front for a rear-driven car."""
    axle = ("fl", "fr") if vehicle.drive == "rwd" else ("rl", "rr")
    omega = 0.5 * (
        np.asarray(stream[f"wheel_speed_{axle[0]}"], dtype=np.float64)
        + np.asarray(stream[f"wheel_speed_{axle[1]}"], dtype=np.float64)
    )
    return omega * float(vehicle.wheel_radius_m)


def _covers(bounds: list[float], truth: float) -> bool:
    return bool(bounds[0] <= truth <= bounds[1])


def evaluate_drive(drive: Drive, config: ParamsdConfig) -> dict:
    """Run the filter on one external drive (``benchmarks._data.Drive``) against its truth."""
    truth = drive.truth
    vehicle = drive.vehicle()
    stream = drive.frame()
    started = _time.perf_counter()
    res = run_paramsd(
        stream["time"].to_numpy(np.float64),
        drive_speed(stream, vehicle),
        stream["yaw_rate"].to_numpy(np.float64),
        stream["steering_wheel_angle"].to_numpy(np.float64),
        vehicle,
        lateral_acceleration=stream["ay"].to_numpy(np.float64),
        config=config,
    )
    wall = _time.perf_counter() - started
    summary = res.to_dict()
    row: dict[str, Any] = {
        "drive": drive.path.name,
        "kind": truth["kind"],
        "vehicle": truth["vehicle"],
    }
    for key, truth_key in (
        ("c_y_front", "c_y_front"),
        ("c_y_rear", "c_y_rear"),
        ("understeer_gradient", "understeer_gradient"),
        ("steering_ratio", "steering_ratio"),
    ):
        est = summary[key]
        row[key] = {
            **est,
            "truth": truth[truth_key],
            "rel_error": est["mean"] / truth[truth_key] - 1.0,
            "covered_2sd": _covers(est["bounds_2sd"], truth[truth_key]),
            "covered_90": _covers(est["hdi_90"], truth[truth_key]),
        }
    row["angle_offset_rad"] = {**summary["angle_offset_rad"], "truth": truth["steering_offset_rad"]}
    row["stiffness_factor"] = summary["stiffness_factor"]
    # The single factor that would give each axle's true stiffness (the two differ: the nominal
    # front/rear ratio is fixed).
    row["stiffness_factor_truth_front"] = truth["c_y_front"] / res.nominal_c_y_front
    row["stiffness_factor_truth_rear"] = truth["c_y_rear"] / res.nominal_c_y_rear
    row["stability"] = summary["stability"]
    # Braking in corners: how fast the factor moves there against everywhere it is active.
    ax = stream["ax"].to_numpy(np.float64)
    ay = stream["ay"].to_numpy(np.float64)
    rate = np.abs(np.gradient(res.stiffness_factor, res.time))
    braking_corner = res.active & (ax < -1.0) & (np.abs(ay) > 1.5)
    row["braking_in_corners"] = {
        "definition": "active, a_x < -1 m/s², |a_y| > 1.5 m/s²",
        "fraction_of_samples": float(np.mean(braking_corner)),
        "mean_abs_rate_per_s": float(np.mean(rate[braking_corner]))
        if braking_corner.any()
        else None,
        "mean_abs_rate_per_s_active": float(np.mean(rate[res.active])),
    }
    row["active_fraction"] = summary["active_fraction"]
    row["valid_fraction"] = summary["valid_fraction"]
    row["sensor_valid_fraction"] = summary["sensor_valid_fraction"]
    row["n_resets"] = summary["n_resets"]
    row["filter_seconds"] = res.seconds
    row["wall_seconds"] = wall
    row["duration_s"] = float(res.time[-1] - res.time[0])
    return row


def main(argv: list[str] | None = None) -> dict:
    """Run every configuration on the external drives; print a table, optionally write JSON."""
    import argparse
    import json

    from _data import EXTERNAL_LATERAL, external_lateral_drives

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir", nargs="?", default=str(EXTERNAL_LATERAL))
    parser.add_argument("--out", default=None)
    parser.add_argument("--drives", default=None, help="comma-separated, e.g. l00,l01")
    parser.add_argument("--use-ay", action="store_true", help="also run each config with a_y")
    args = parser.parse_args(argv)

    root = Path(args.dir)
    drives = external_lateral_drives(root, args.drives or "")
    configs = dict(CONFIGS)
    if args.use_ay:
        configs.update(
            {f"{k}+ay": ParamsdConfig(**{**c.__dict__, "use_ay": True}) for k, c in CONFIGS.items()}
        )
    results: dict[str, Any] = {"configs": {}, "source": str(root)}
    for cname, cfg in configs.items():
        rows = [evaluate_drive(drive, cfg) for drive in drives]
        results["configs"][cname] = {"config": dict(cfg.__dict__), "drives": rows}
        print(f"\n{cname}")
        print(
            f"{'drive':6} {'kind':6} {'x':>6} {'cyf':>6} {'true':>6} {'cyr':>6} {'true':>6} "
            f"{'K e3':>6} {'true':>6} {'sr':>6} {'true':>6} cov2sd(f,r,K,sr) "
            f"{'xstd':>7} {'xmin':>6} {'xmax':>6} {'s':>5}"
        )
        for row in rows:
            cov = "".join(
                "Y" if row[k]["covered_2sd"] else "n"
                for k in ("c_y_front", "c_y_rear", "understeer_gradient", "steering_ratio")
            )
            st = row["stability"]
            print(
                f"{row['drive'][:3]:6} {row['kind']:6} {row['stiffness_factor']['mean']:6.3f} "
                f"{row['c_y_front']['mean']:6.2f} {row['c_y_front']['truth']:6.2f} "
                f"{row['c_y_rear']['mean']:6.2f} {row['c_y_rear']['truth']:6.2f} "
                f"{1e3 * row['understeer_gradient']['mean']:6.2f} "
                f"{1e3 * row['understeer_gradient']['truth']:6.2f} "
                f"{row['steering_ratio']['mean']:6.2f} {row['steering_ratio']['truth']:6.2f} "
                f"{cov:16} {st['stiffness_factor_std']:7.4f} {st['stiffness_factor_min']:6.3f} "
                f"{st['stiffness_factor_max']:6.3f} {row['wall_seconds']:5.1f}"
            )
    if args.out:
        Path(args.out).write_text(json.dumps(results, indent=1, default=_json_default) + "\n")
    return results


def _json_default(value):
    if isinstance(value, tuple):
        return list(value)
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value)}")


if __name__ == "__main__":
    main()
