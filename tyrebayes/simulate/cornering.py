"""Simulate cornering with known lateral truth: a single-track car on Magic Formula axles.

The package's drive simulator (:mod:`.drive`) is quasi-static in yaw (ψ̇ = a_y/V), which is
right for the longitudinal fit and carries no yaw transients. This one integrates the single-track
dynamics (thesis eq. 4.22/4.23, :func:`~tyrebayes.physics.vehicle.single_track_derivatives`)
with each axle's force from a Magic Formula curve over its static load, driven by a planned speed
and a steering input, and writes the sensors a car has: rear-wheel speeds, a body-fixed a_y that
rolls with the body (gain 1 + g k_φ) and has an offset, a gyro, and a steering-wheel angle through
a ratio and an offset. It shares the lateral model's assumptions: a test of the code, not of the
method (the external drives are that).

The planned manoeuvre (``manoeuvre``): ``"mixed"`` (town corners, bends and lane changes at
8-30 m/s), ``"steady"`` (long highway curves at one speed: no yaw transients) or ``"straight"``
(no cornering).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pandas as pd
from scipy.interpolate import CubicSpline

from ..internal.renamed import renamed_keyword
from ..physics.vehicle import SingleTrackState, Vehicle, single_track_derivatives

G = 9.80665


@dataclasses.dataclass(frozen=True)
class CorneringTruth:
    """What a simulated cornering drive was made with (per-axle values over the static load).

    ``shape`` and ``curvature`` are the front axle's Magic Formula C and E, ``shape_rear`` and
    ``curvature_rear`` the rear's.
    """

    c_y_front: float
    c_y_rear: float
    mu_y: float
    shape: float
    curvature: float
    steering_ratio: float
    steering_offset_rad: float
    roll_gradient: float
    ay_offset: float
    manoeuvre: str
    shape_rear: float
    curvature_rear: float

    @property
    def understeer_gradient(self) -> float:
        """K = (1/c_f − 1/c_r)/g [rad/(m/s²)]."""
        return (1.0 / self.c_y_front - 1.0 / self.c_y_rear) / G


def _magic(alpha, c, mu, shape, curvature):
    """Magic Formula force over load at slip angle ``alpha`` [rad] (slope ``c``, peak ``mu``)."""
    b = c / (shape * mu)
    x = b * alpha
    return mu * jnp.sin(shape * jnp.arctan(x - curvature * (x - jnp.arctan(x))))


def _smooth(rng: np.random.Generator, n: int, dt: float, corner_hz: float) -> np.ndarray:
    """Unit-sd noise low-passed at ``corner_hz`` (a first-order filter run both ways)."""
    x = rng.normal(size=n)
    k = 1.0 - np.exp(-2 * np.pi * corner_hz * dt)
    for _ in range(2):
        y = np.empty(n)
        acc = 0.0
        for i in range(n):
            acc += k * (x[i] - acc)
            y[i] = acc
        x = y[::-1]
    return x / (np.std(x) + 1e-12)


def _plan(manoeuvre: str, rng, n: int, dt: float, vehicle: Vehicle, k_guess: float):
    """Speed [m/s] and road-wheel angle [rad] that aim at a planned a_y."""
    wheelbase = float(vehicle.wheelbase_m)
    if manoeuvre == "steady":
        speed = 27.0 + 1.0 * _smooth(rng, n, dt, 0.005)
        ay = 2.0 * _smooth(rng, n, dt, 0.01)
    elif manoeuvre == "mixed":
        speed = np.clip(18.0 + 7.0 * _smooth(rng, n, dt, 0.01), 8.0, 32.0)
        ay = 2.0 * _smooth(rng, n, dt, 0.08) + 1.5 * _smooth(rng, n, dt, 0.4)
        ay = np.clip(ay, -5.0, 5.0)
    elif manoeuvre == "straight":
        speed = 20.0 + 3.0 * _smooth(rng, n, dt, 0.01)
        ay = 0.05 * _smooth(rng, n, dt, 0.1)
    else:
        raise ValueError(f"manoeuvre: expected 'mixed', 'steady' or 'straight', got {manoeuvre!r}")
    # Start from straight running: the car starts at rest in yaw (v_y = r = 0).
    ay = ay * np.clip(np.arange(n) * dt / 3.0, 0.0, 1.0)
    delta = (wheelbase / speed**2 + k_guess) * ay
    return speed, delta


@renamed_keyword("kind", "manoeuvre", what="'mixed', 'steady' or 'straight'")
def simulate_cornering(
    vehicle: Vehicle,
    *,
    manoeuvre: str = "mixed",
    duration_s: float = 300.0,
    seed: int = 0,
    c_y_front: float = 14.0,
    c_y_rear: float = 18.0,
    mu_y: float = 1.0,
    shape: float = 1.35,
    curvature: float = -0.5,
    shape_rear: float | None = None,
    curvature_rear: float | None = None,
    steering_ratio_error: float = 0.02,
    steering_offset_rad: float = 0.01,
    roll_gradient: float = 0.008,
    ay_offset: float = 0.05,
    rate_hz: float = 100.0,
    noise: bool = True,
) -> tuple[pd.DataFrame, CorneringTruth]:
    """A stream (package contract) and its truth; module docstring for what is simulated.

    ``shape`` and ``curvature`` are the Magic Formula C and E of the front axle's curve, and of
    the rear's unless ``shape_rear`` and ``curvature_rear`` are given: an axle's curve includes
    its load transfer, which differs between the axles.

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> frame, truth = simulate_cornering(load_vehicle("compact_fwd"), duration_s=20.0)
    >>> sorted(frame.columns)[:3], round(truth.understeer_gradient, 5)
    (['ax', 'ay', 'lateral_velocity'], 0.00162)
    """
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    substeps = 10  # RK4 at 10x the output rate: the yaw mode at 8 m/s is fast (~20 /s)
    n = int(round(duration_s * rate_hz))
    truth = CorneringTruth(
        c_y_front=c_y_front,
        c_y_rear=c_y_rear,
        mu_y=mu_y,
        shape=shape,
        curvature=curvature,
        steering_ratio=float(vehicle.steering_ratio) * (1.0 + steering_ratio_error),
        steering_offset_rad=steering_offset_rad,
        roll_gradient=roll_gradient,
        ay_offset=ay_offset,
        manoeuvre=manoeuvre,
        shape_rear=shape if shape_rear is None else shape_rear,
        curvature_rear=curvature if curvature_rear is None else curvature_rear,
    )
    fine = np.arange(n * substeps) * (dt / substeps)
    speed, delta = _planned_inputs(manoeuvre, rng, vehicle, truth, duration_s, fine)
    vy, r, ay_true = _integrate(vehicle, truth, speed, delta, dt / substeps)
    vy, r, ay_true = (np.asarray(x, float)[::substeps] for x in (vy, r, ay_true))
    speed, delta = speed[::substeps], delta[::substeps]
    frame = _sensor_frame(rng, vehicle, truth, speed, delta, vy, r, ay_true, dt, noise)
    return frame, truth


def _planned_inputs(
    manoeuvre: str,
    rng: np.random.Generator,
    vehicle: Vehicle,
    truth: CorneringTruth,
    duration_s: float,
    fine: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Speed [m/s] and road-wheel angle [rad] at the times ``fine`` [s]: a smooth plan."""
    # The plan on a 10 Hz grid, interpolated by a cubic spline: a driver's inputs are smooth, and
    # the tyres answer a steering step at once (no relaxation here), so an input that is only
    # continuous would put a sample-rate yaw transient into every step.
    plan_dt = 0.1
    n_plan = int(np.ceil(duration_s / plan_dt)) + 2
    speed_plan, delta_plan = _plan(
        manoeuvre, rng, n_plan, plan_dt, vehicle, truth.understeer_gradient
    )
    plan_time = np.arange(n_plan) * plan_dt
    speed = CubicSpline(plan_time, speed_plan)(fine)
    delta = CubicSpline(plan_time, delta_plan)(fine)
    return speed, delta


def _integrate(
    vehicle: Vehicle, truth: CorneringTruth, speed: np.ndarray, delta: np.ndarray, h: float
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """v_y [m/s], yaw rate [rad/s] and a_y [m/s²] of the single-track car (RK4, step ``h`` [s])."""
    m, lf = float(vehicle.mass_kg), float(vehicle.cog_to_front_axle_m)
    lr = float(vehicle.cog_to_rear_axle_m)
    fz_front, fz_rear = m * G * lr / (lf + lr), m * G * lf / (lf + lr)

    def forces(vy, r, vx, d):
        alpha_f = d - (vy + lf * r) / vx
        alpha_r = -(vy - lr * r) / vx
        fy_f = fz_front * _magic(alpha_f, truth.c_y_front, truth.mu_y, truth.shape, truth.curvature)
        fy_r = fz_rear * _magic(
            alpha_r, truth.c_y_rear, truth.mu_y, truth.shape_rear, truth.curvature_rear
        )
        return fy_f, fy_r

    def deriv(x, vx, d):
        fy_f, fy_r = forces(x[0], x[1], vx, d)
        state = SingleTrackState(vx_mps=vx, vy_mps=x[0], yaw_rate_radps=x[1])
        dstate = single_track_derivatives(vehicle, state, 0.0, 0.0, fy_f, 0.0, fy_r)
        return jnp.stack([dstate.vy_mps, dstate.yaw_rate_radps]), (fy_f + fy_r) / m

    def step(x, inputs):
        # RK4 with the inputs at the step's start, middle and end.
        (v0, d0), (v1, d1) = inputs
        vm, dm = 0.5 * (v0 + v1), 0.5 * (d0 + d1)
        k1, ay = deriv(x, v0, d0)
        k2 = deriv(x + 0.5 * h * k1, vm, dm)[0]
        k3 = deriv(x + 0.5 * h * k2, vm, dm)[0]
        k4 = deriv(x + h * k3, v1, d1)[0]
        return x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4), (x[0], x[1], ay)

    speed_next = np.append(speed[1:], speed[-1])
    delta_next = np.append(delta[1:], delta[-1])
    inputs = ((jnp.asarray(speed), jnp.asarray(delta)), (speed_next, delta_next))
    _, (vy, r, ay_true) = jax.lax.scan(step, jnp.zeros(2), inputs)
    return vy, r, ay_true


def _sensor_frame(
    rng: np.random.Generator,
    vehicle: Vehicle,
    truth: CorneringTruth,
    speed: np.ndarray,
    delta: np.ndarray,
    vy: np.ndarray,
    r: np.ndarray,
    ay_true: np.ndarray,
    dt: float,
    noise: bool,
) -> pd.DataFrame:
    """The stream a car's sensors log of the motion (noise drawn even when ``noise`` is off)."""
    n = speed.shape[0]
    vx_dot = np.gradient(speed, dt)
    scale = 1.0 if noise else 0.0
    radius = float(vehicle.wheel_radius_m)
    wheel = speed / radius
    time = np.arange(n) * dt
    return pd.DataFrame(
        {
            "time": time,
            **{
                f"wheel_speed_{w}": wheel + scale * rng.normal(0, 0.02, n)
                for w in ("fl", "fr", "rl", "rr")
            },
            "ax": vx_dot - r * vy + scale * rng.normal(0, 0.05, n),
            "ay": (1.0 + G * truth.roll_gradient) * ay_true
            + truth.ay_offset
            + scale * rng.normal(0, 0.05, n),
            "lateral_velocity": vy,
            "yaw_rate": r + scale * rng.normal(0, 0.002, n),
            "steering_wheel_angle": truth.steering_ratio * delta
            + truth.steering_offset_rad
            + scale * rng.normal(0, 0.002, n),
        }
    )
