"""Simulate one drive: a planned speed profile through vehicle and tyre physics into sensor logs.

Pipeline (all vectorised NumPy on a uniform grid; the thermal model runs in JAX at 1 Hz):

1. :func:`~tyrebayes.simulate.profiles.make_profile` plans V(t), a_y(t), grade θ(t) and events.
2. Lateral: the path's yaw rate ψ̇ = a_y/V (a_y the plan's); the rear axle's slip angle
   tan α_r = (l_r ψ̇ − v_y)/V on the brush lateral curve (C_y, μ) and the yaw moment balance
   (eq. 4.23b, c, as in :func:`~tyrebayes.physics.vehicle.single_track_inverse`) make the body's
   lateral acceleration V ψ̇ + v̇_y a first-order equation in v_y, integrated exactly per sample
   interval; the front axle's slip angle from its force; road-wheel angle δ = κ L + α_f − α_r.
   The logged a_y is V ψ̇ + v̇_y.
3. Longitudinal: the tyres must supply m a_x + drag + f_rr m g cos θ + m g sin θ (+ the steered
   front lateral force's drag, eq. 4.23a). Traction goes to the driven axle(s) by the drive's
   split; braking first uses engine braking on the driven axle (up to 0.05 m g), the rest is
   distributed in proportion to the axle loads (an EBD-like ideal distribution). Each axle's force
   is shared equally by its wheels (open differential, equal brake pressure); wheel loads include
   longitudinal and lateral load transfer (:func:`~tyrebayes.physics.vehicle.wheel_loads`).
4. Tyre temperature: :func:`~tyrebayes.physics.thermal.simulate_tyre_temperature` per wheel with
   rolling loss and friction heating; C_x(t) = C_x(C_xr, T(t)) (``StiffnessTemperature``).
5. Slip per wheel by inverting the truth curve (brush closed form, Magic Formula Newton).
6. ABS events: the controller cycles each wheel's slip around its peak (0.5–1.5 σ_peak, ~4 Hz,
   wheel-individual phases), so the deceleration is what the tyres deliver at and beyond μ_max; the
   planned speed is replaced by the resulting one and the following recovery segment absorbs the
   difference.
7. Wheel speeds Ω_i = v_i (1 + σ_i)/R_i with the wheel-centre speed v_i (yaw rate and steering) and
   per-wheel radii R_i = R_nom (1 + ε_i); then :func:`~tyrebayes.simulate.sensors.measure`.

Simplifications (stated so that nobody mistakes them for findings): pure longitudinal slip (no
combined-slip reduction of F_x in corners); the yaw rate follows the planned path (no steering
input integrated, no tyre relaxation); the thermal input uses
the linear slip ρ/C_xr for the (small) friction power outside ABS; radius does not change with load
or speed; ABS only on straight road.

Examples
--------
>>> df, truth = simulate_drive(1, "suv_rav4", "summer", duration_s=30.0, ambient_c=15.0)
>>> list(df.columns[:5])
['time', 'wheel_speed_fl', 'wheel_speed_fr', 'wheel_speed_rl', 'wheel_speed_rr']
>>> bool(abs(truth.c_xr - 55.0) < 1e-12)
True
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import numpy as np
import pandas as pd

from .._domain import SURFACES, load_vehicle
from ..physics.thermal import ThermalParams, temperature_sensitivity
from ..physics.vehicle import GRAVITY_MPS2, Vehicle
from .abs_braking import _ABS, _apply_abs
from .abs_braking import ABS_HZ as ABS_HZ
from .abs_braking import ABS_SWING as ABS_SWING
from .drive_forces import ENGINE_BRAKE_SHARE as ENGINE_BRAKE_SHARE
from .drive_forces import MIN_SLIP_SPEED_MPS as MIN_SLIP_SPEED_MPS
from .drive_forces import _Kinematics, _kinematics, _wheel_rho
from .drive_forces import wheel_loads_np as wheel_loads_np
from .drive_thermal import _temperatures
from .profiles import DriveProfile, ProfileOptions, make_profile
from .seeds import _seed_int
from .seeds import drawn_curve as drawn_curve
from .seeds import seed_sequence as seed_sequence
from .sensors import SensorModel, SensorTruth, draw_sensor_truth, measure, sample_times
from .truth import DriveTruth
from .tyre_curves import peak_slip, tyre_force, tyre_slip
from .tyre_spec import TYRE_MODELS, TyreSpec


def _resolve_inputs(vehicle, tyre, surface, tyre_model, sensor, profile):
    name = ""
    if isinstance(vehicle, str):
        name = vehicle
        vehicle = load_vehicle(vehicle)
    if not isinstance(vehicle, Vehicle):
        raise ValueError(
            f"vehicle: expected a Vehicle or a preset name, got {type(vehicle).__name__}"
        )
    if isinstance(tyre, str):
        tyre = TyreSpec.from_type(tyre)
    if not isinstance(tyre, TyreSpec):
        raise ValueError(
            f"tyre: expected a TyreSpec or a tyre type name, got {type(tyre).__name__}"
        )
    if surface not in SURFACES:
        raise ValueError(f"surface: expected one of {SURFACES}, got {surface!r}")
    if tyre_model not in TYRE_MODELS:
        raise ValueError(f"tyre_model: expected one of {TYRE_MODELS}, got {tyre_model!r}")
    return name, vehicle, tyre, sensor or SensorModel(), profile or ProfileOptions()


def simulate_drive(
    key_or_seed,
    vehicle: Vehicle | str,
    tyre: TyreSpec | str,
    *,
    duration_s: float | int,
    sample_rate_hz: float | int = 100.0,
    surface: str = "dry",
    ambient_c: float | int = 20.0,
    profile: ProfileOptions | None = None,
    tyre_model: str = "magic_formula",
    sensor: SensorModel | None = None,
    thermal: ThermalParams | None = None,
    initial_tyre_temp_c: float | int | None = None,
    sensor_offsets: SensorTruth | None = None,
    planned: DriveProfile | None = None,
) -> tuple[pd.DataFrame, DriveTruth]:
    """Simulate one drive and return its logged stream and its truth.

    Parameters
    ----------
    key_or_seed : int or jax PRNG key
        Seed; the profile, the sensor offsets and the sensor noise use independent streams of it,
        so changing the sensor model does not change the route.
    vehicle : Vehicle or str
        The car (preset names: ``compact_fwd``, ``suv_rav4``).
    tyre : TyreSpec or str
        The true tyre, or a type name (``winter``, ``all_season``, ``summer``): a typical tyre of
        that type whose Magic Formula shape is drawn from the shipped database of measured
        tyres (:func:`~tyrebayes.simulate.tyre_spec.draw_database_curve`).
    duration_s : float
        Duration [s].
    sample_rate_hz : float
        Logging rate [Hz] (the issue asks for 50–100 Hz).
    surface : str
        ``dry``, ``wet``, ``snow`` or ``ice``: selects μ_max of the tyre and limits the driving.
    ambient_c : float
        Ambient temperature [°C]; the tyres start at it unless ``initial_tyre_temp_c`` is given.
    profile : ProfileOptions, optional
        The driver (speeds, events: hard braking, ABS, corners, lane changes, grade).
    tyre_model : str
        ``"magic_formula"`` (default: real tyres' curves) or ``"brush"`` truth (see
        :mod:`tyrebayes.simulate.tyre_curves`).
    sensor : SensorModel, optional
        Noise, quantisation, offsets, dropouts (defaults resemble the real RAV4 log).
    thermal : ThermalParams, optional
        Tyre heat balance (default: the vehicle's rolling resistance, other defaults).
    initial_tyre_temp_c : float, optional
        Tyre temperature at t = 0 [°C] (default: ambient).
    sensor_offsets : SensorTruth, optional
        Fixed radius errors / IMU offsets (e.g. shared by several drives of one car); drawn from
        ``sensor`` when omitted.
    planned : DriveProfile, optional
        Replay this profile (e.g. :func:`~tyrebayes.simulate.profiles.profile_from_trace` of a
        real log's speed) instead of planning one; ``duration_s`` and ``sample_rate_hz`` must
        match it.

    Returns
    -------
    (stream, truth) : (pandas.DataFrame, DriveTruth)
        The stream in the DESIGN.md contract and the truth aligned with its rows.

    Raises
    ------
    ValueError
        On an unknown surface, tyre model, vehicle or tyre, or invalid durations/rates.
    """
    tyre_given_by_type = isinstance(tyre, str)
    vehicle_name, vehicle, tyre, sensor, opts = _resolve_inputs(
        vehicle, tyre, surface, tyre_model, sensor, profile
    )
    duration_s, sample_rate_hz, ambient_c = _checked_numbers(duration_s, sample_rate_hz, ambient_c)
    seq = seed_sequence(key_or_seed)
    # The fifth stream is the curve's (drawn_curve).
    rng_profile, rng_offsets, rng_sensor, rng_abs = (
        np.random.default_rng(s) for s in seq.spawn(5)[:4]
    )
    if tyre_given_by_type:
        # A tyre named by its type gets a curve shape drawn from the measured tyres' database
        # (its own stream of the seed: the route and the sensors stay as they were).
        tyre = eqx.tree_at(lambda t: t.magic_formula, tyre, drawn_curve(key_or_seed))
    mu = tyre.mu_on(surface)
    thermal = thermal or ThermalParams(rolling_resistance=vehicle.rolling_resistance)
    t0_tyre = ambient_c if initial_tyre_temp_c is None else float(initial_tyre_temp_c)

    # 1. Plan.
    static = wheel_loads_np(vehicle, 0.0, 0.0)
    plan = _plan(rng_profile, vehicle, static, mu, opts, duration_s, sample_rate_hz, planned)

    # 2-6. Forces, tyre temperatures, ABS and each wheel's slip.
    state = _tyre_states(
        rng_abs, plan, vehicle, tyre, tyre_model, mu, thermal, static, ambient_c, t0_tyre
    )

    # 7. Wheel-centre speeds (yaw rate and steering) and wheel speeds.
    offsets = sensor_offsets or draw_sensor_truth(rng_offsets, sensor, vehicle.wheel_radius_m)
    radius = vehicle.wheel_radius_m * (1.0 + np.asarray(offsets.radius_error))
    v_wheel = _wheel_centre_speeds(vehicle, state.kin, state.v)
    omega = v_wheel * (1.0 + state.slip) / radius[None, :]

    # Sample times (jitter) and the logged stream.
    t_log = sample_times(rng_sensor, len(state.v), sample_rate_hz, sensor.timing_jitter)
    stream = _logged_stream(
        rng_sensor, sensor, offsets, vehicle, plan, state, t_log, omega, ambient_c
    )
    truth = _drive_truth(
        vehicle_name=vehicle_name,
        vehicle=vehicle,
        tyre=tyre,
        surface=surface,
        tyre_model=tyre_model,
        seed=_seed_int(key_or_seed),
        mu=mu,
        ambient_c=ambient_c,
        static=static,
        plan=plan,
        state=state,
        offsets=offsets,
        radius=radius,
        v_wheel=v_wheel,
        t_log=t_log,
    )
    return stream, truth


class _TyreStates(NamedTuple):
    """Steps 2-6's outcome: the final motion and each wheel's slip, force and stiffness."""

    v: np.ndarray  # speed after ABS [m/s]
    kin: _Kinematics  # forces and loads of the final motion
    slip: np.ndarray  # (n, 4) slip (0 below MIN_SLIP_SPEED_MPS) [-]
    rho: np.ndarray  # (n, 4) normalised force [-]
    ok: np.ndarray  # (n, 4) whether the truth curve had a slip for the force
    in_abs: np.ndarray  # (n,) ABS samples
    c_x_wheel: np.ndarray  # (n, 4) slip stiffness at the tyre temperature [-]
    temps: np.ndarray  # (n, 4) tyre temperature [°C]


def _tyre_states(
    rng_abs, plan, vehicle, tyre, tyre_model, mu, thermal, static, ambient_c, t0_tyre
) -> _TyreStates:
    """Steps 2-6: forces of the plan, tyre temperatures, ABS, then slips of the final motion."""
    dt = plan.dt_s
    v, a, ay, grade = plan.speed_mps, plan.accel_mps2, plan.ay_mps2, plan.grade_rad

    # 2-4. Forces of the plan, then tyre temperatures (friction power from the linear slip).
    kin = _kinematics(vehicle, tyre, mu, v, a, ay, grade, dt)
    rho = _wheel_rho(kin)
    abs_mask = plan.long_label == _ABS
    slip_lin = np.clip(rho / tyre.c_xr, -3 * mu / tyre.c_xr, 3 * mu / tyre.c_xr)
    slip_lin[abs_mask] = -3 * mu / tyre.c_xr  # ABS runs around the peak slip
    friction_w = np.abs(rho * kin.fz * v[:, None] * slip_lin)
    temps = _temperatures(thermal, dt, v, kin.fz, friction_w, ambient_c, t0_tyre)
    beta = float(temperature_sensitivity(tyre.c_xr, tyre.stiffness_temperature))
    t_ref = float(tyre.stiffness_temperature.reference_temperature_c)
    c_x_wheel = tyre.c_xr * np.exp(-beta * (temps - t_ref))

    # 6. ABS: the tyres decide the deceleration; then recompute all forces with the final motion.
    v, a, abs_slip = _apply_abs(
        rng_abs, plan, vehicle, tyre, tyre_model, mu, c_x_wheel, static, v, a, grade
    )
    kin = _kinematics(vehicle, tyre, mu, v, a, ay, grade, dt)
    rho = _wheel_rho(kin)

    # 5. Slip by inverting the truth curve; ABS samples keep their prescribed slip.
    slip, rho, ok, in_abs = _slips(tyre_model, tyre, mu, kin, rho, c_x_wheel, static, abs_slip, v)
    return _TyreStates(v, kin, slip, rho, ok, in_abs, c_x_wheel, temps)


def _at_log(x: np.ndarray) -> np.ndarray:
    """A true signal at the logged rows (the identity: the rows align one to one).

    The ECU samples on its regular clock; the logger stamps each value on arrival, so jitter
    is in the time stamps only (CAN receive-time jitter), and the truth rows align one to one.
    """
    return x


def _logged_stream(
    rng_sensor, sensor, offsets, vehicle, plan, state, t_log, omega, ambient_c
) -> pd.DataFrame:
    """The sensors' view of the drive (:func:`~tyrebayes.simulate.sensors.measure`)."""
    kin = state.kin
    steer_wheel = kin.delta * vehicle.steering_ratio
    return measure(
        rng_sensor,
        sensor,
        offsets,
        time_s=t_log,
        wheel_speed_radps=_at_log(omega),
        accel_mps2=_at_log(kin.ax),
        ay_mps2=_at_log(kin.ay),
        grade_rad=_at_log(plan.grade_rad),
        yaw_rate_radps=_at_log(kin.yaw),
        steering_wheel_angle_rad=_at_log(steer_wheel),
        speed_mps=_at_log(np.hypot(state.v, kin.vy)),
        ambient_c=ambient_c,
        wheelbase_m=vehicle.wheelbase_m,
        pitch_gradient_rad_per_mps2=vehicle.pitch_gradient_rad_per_mps2,
    )


def _drive_truth(
    *,
    vehicle_name,
    vehicle,
    tyre,
    surface,
    tyre_model,
    seed,
    mu,
    ambient_c,
    static,
    plan,
    state,
    offsets,
    radius,
    v_wheel,
    t_log,
) -> DriveTruth:
    """The drive's truth, row by row with its stream, with the driven-axle summary."""
    kin, slip, c_x_wheel, in_abs = state.kin, state.slip, state.c_x_wheel, state.in_abs
    fx_wheel = state.rho * kin.fz
    fx_front = np.where(in_abs, fx_wheel[:, 0] + fx_wheel[:, 1], kin.fx_front)
    fx_rear = np.where(in_abs, fx_wheel[:, 2] + fx_wheel[:, 3], kin.fx_rear)
    idx = _DRIVEN_WHEELS.get(vehicle.drive, [0, 1, 2, 3])
    slip_driven = slip[:, idx].mean(axis=1)
    rho_driven = fx_wheel[:, idx].sum(axis=1) / kin.fz[:, idx].sum(axis=1)
    c_x = c_x_wheel[:, idx].mean(axis=1)
    friction_total = np.abs(fx_wheel * v_wheel * slip).sum(axis=1)
    abs_pk = _abs_peak_slip(tyre_model, tyre, mu, static, c_x_wheel, in_abs, idx)
    return DriveTruth(
        vehicle_name=vehicle_name,
        drive=vehicle.drive,
        surface=surface,
        tyre_model=tyre_model,
        seed=seed,
        c_xr=float(tyre.c_xr),
        mu_max=float(mu),
        mu_slide_ratio=float(tyre.mu_slide_ratio),
        c_y_per_rad=float(tyre.c_y_per_rad),
        ambient_c=float(ambient_c),
        mounting_pitch_rad=float(offsets.mounting_pitch_rad),
        ax_gain=float(offsets.ax_gain),
        yaw_rate_bias_radps=float(offsets.yaw_rate_bias_radps),
        wheel_speed_step_radps=float(offsets.wheel_speed_step_radps),
        abs_peak_slip=abs_pk,
        radius_m=radius,
        radius_error=np.asarray(offsets.radius_error, dtype=float),
        slip_offset=1.0 / (1.0 + np.asarray(offsets.radius_error, dtype=float)) - 1.0,
        imu_bias_mps2=np.asarray(offsets.imu_bias_mps2, dtype=float),
        fz_static_n=static,
        time_s=t_log,
        vx_mps=_at_log(state.v),
        vy_mps=_at_log(kin.vy),
        ax_mps2=_at_log(kin.ax),
        ay_mps2=_at_log(kin.ay),
        yaw_rate_radps=_at_log(kin.yaw),
        road_wheel_angle_rad=_at_log(kin.delta),
        grade_rad=_at_log(plan.grade_rad),
        c_x=_at_log(c_x),
        slip_driven=_at_log(slip_driven),
        rho_x_driven=_at_log(rho_driven),
        fx_front_n=_at_log(fx_front),
        fx_rear_n=_at_log(fx_rear),
        friction_power_w=_at_log(friction_total),
        long_label=plan.long_label,
        lat_label=plan.lat_label,
        force_clipped=~state.ok.all(axis=1) | kin.clipped,
        slip=_at_log(slip),
        rho_x=_at_log(state.rho),
        wheel_load_n=_at_log(kin.fz),
        wheel_centre_speed_mps=_at_log(v_wheel),
        c_x_wheel=_at_log(c_x_wheel),
        tyre_temperature_c=_at_log(state.temps),
    )


def _checked_numbers(duration_s, sample_rate_hz, ambient_c) -> tuple[float, float, float]:
    """The duration, rate and ambient temperature as floats; a ValueError for a bad one."""
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s: expected a finite value > 0, got {duration_s!r}")
    if not (np.isfinite(sample_rate_hz) and 10.0 <= sample_rate_hz <= 1000.0):
        raise ValueError(f"sample_rate_hz: expected a value in [10, 1000], got {sample_rate_hz!r}")
    if not np.isfinite(ambient_c) or not -50.0 <= ambient_c <= 60.0:
        raise ValueError(f"ambient_c: expected a value in [-50, 60] °C, got {ambient_c!r}")
    if round(duration_s * sample_rate_hz) < 2:
        raise ValueError(
            f"duration_s: expected at least 2 samples, got {duration_s} s at {sample_rate_hz} Hz"
        )
    return float(duration_s), float(sample_rate_hz), float(ambient_c)


def _plan(
    rng_profile: np.random.Generator,
    vehicle: Vehicle,
    static: np.ndarray,
    mu: float,
    opts: ProfileOptions,
    duration_s: float,
    sample_rate_hz: float,
    planned: DriveProfile | None,
) -> DriveProfile:
    """Step 1: the planned motion, or ``planned`` checked against the rate."""
    g = GRAVITY_MPS2
    # The driven axle's static load share limits ordinary accelerations.
    share = vehicle.traction_front_share
    if vehicle.drive == "awd":
        driven_share = 1.0
    else:
        axle = (static[0] + static[1]) if share == 1.0 else (static[2] + static[3])
        driven_share = float(axle / (vehicle.mass_kg * g))
    if planned is None:
        return make_profile(
            rng_profile,
            duration_s=duration_s,
            sample_rate_hz=sample_rate_hz,
            mu_surface=mu,
            options=opts,
            traction_limit_mps2=0.3 * mu * g * driven_share,
        )
    if abs(planned.dt_s * sample_rate_hz - 1.0) > 1e-9:
        raise ValueError(
            f"planned: expected a profile at {sample_rate_hz} Hz, got {1.0 / planned.dt_s} Hz"
        )
    return planned


def _slips(tyre_model, tyre, mu, kin, rho, c_x_wheel, static, abs_slip, v):
    """Step 5: each wheel's slip from the truth curve, ABS samples at their prescribed slip.

    Returns ``(slip, rho, ok, in_abs)``: the slips (0 below :data:`MIN_SLIP_SPEED_MPS`), the
    forces (at 0.97 μ where the curve has no slip for them), whether it had, and the ABS samples.
    """
    slip, ok = tyre_slip(tyre_model, rho, kin.fz, c_x_wheel, mu, tyre, static[None, :])
    in_abs = ~np.isnan(abs_slip[:, 0])
    slip[in_abs] = abs_slip[in_abs]
    rho[in_abs] = tyre_force(
        tyre_model, slip[in_abs], kin.fz[in_abs], c_x_wheel[in_abs], mu, tyre, static[None, :]
    )
    ok[in_abs] = True
    rho = np.where(ok, rho, np.sign(rho) * 0.97 * mu)
    moving = v > MIN_SLIP_SPEED_MPS
    slip = np.where(moving[:, None], slip, 0.0)
    return slip, rho, ok, in_abs


def _wheel_centre_speeds(vehicle: Vehicle, kin, v: np.ndarray) -> np.ndarray:
    """Step 7: each wheel centre's speed along the wheel (yaw rate and steering) [m/s]."""
    half = vehicle.track_width_m / 2
    lf = vehicle.cog_to_front_axle_m
    y = np.array([half, -half, half, -half])
    vx_w = v[:, None] - kin.yaw[:, None] * y[None, :]
    front_lat = kin.vy + kin.yaw * lf
    cd, sd = np.cos(kin.delta), np.sin(kin.delta)
    v_wheel = vx_w.copy()
    v_wheel[:, :2] = vx_w[:, :2] * cd[:, None] + (front_lat * sd)[:, None]
    return v_wheel


# The driven wheels (fl, fr, rl, rr = 0..3) by drive; AWD: all four.
_DRIVEN_WHEELS = {"fwd": [0, 1], "rwd": [2, 3]}


def _abs_peak_slip(tyre_model, tyre, mu, static, c_x_wheel, in_abs, idx) -> float:
    """Mean peak slip of the driven wheels over the ABS samples (NaN without ABS)."""
    if not in_abs.any():
        return float("nan")
    return float(
        np.mean(
            peak_slip(
                tyre_model,
                static[None, idx],
                c_x_wheel[in_abs][:, idx],
                mu,
                tyre,
                static[None, idx],
            )
        )
    )
