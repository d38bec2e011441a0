"""The forces of a planned motion: wheel loads, axle forces and each wheel's ρ_x = F_x/F_z.

Steps 2-3 of :mod:`tyrebayes.simulate.drive` (eqs. 4.23a-c as in
:func:`~tyrebayes.physics.vehicle.single_track_inverse`), in NumPy for drives of any length.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np

from ..physics.vehicle import AIR_DENSITY_KGPM3, GRAVITY_MPS2, Vehicle
from .tyre_curves import MAX_UTILISATION, brush_force_np, brush_inverse_np
from .tyre_spec import TyreSpec

#: Engine-braking force available on the driven axle, as a share of the weight.
ENGINE_BRAKE_SHARE = 0.05


#: Minimum speed for slip to be defined [m/s]; below it the truth slip is 0.
MIN_SLIP_SPEED_MPS = 0.5


def wheel_loads_np(vehicle: Vehicle, ax, ay) -> np.ndarray:
    """NumPy twin of :func:`tyrebayes.physics.vehicle.wheel_loads` (fl, fr, rl, rr) [N].

    Eager JAX compiles each primitive for every new array length; this twin keeps the simulator
    fast for drives of any length. Tests check it against the physics module.
    """
    ax, ay = np.broadcast_arrays(np.asarray(ax, dtype=float), np.asarray(ay, dtype=float))
    m, h, wb = vehicle.mass_kg, vehicle.cog_height_m, vehicle.wheelbase_m
    weight = m * GRAVITY_MPS2
    transfer = m * ax * h / wb
    front = weight * vehicle.cog_to_rear_axle_m / wb - transfer
    rear = weight * vehicle.cog_to_front_axle_m / wb + transfer
    lateral = m * ay * h / vehicle.track_width_m
    share = vehicle.cog_to_rear_axle_m / wb
    return np.stack(
        [
            front / 2 - lateral * share,
            front / 2 + lateral * share,
            rear / 2 - lateral * (1 - share),
            rear / 2 + lateral * (1 - share),
        ],
        axis=-1,
    )


class _Kinematics(eqx.Module):
    """Forces and loads of every sample for a given speed/acceleration history."""

    ax: np.ndarray  # body a_x (no gravity) [m/s²]
    ay: np.ndarray  # body a_y, V ψ̇ + v̇_y (no gravity) [m/s²]
    vy: np.ndarray
    yaw: np.ndarray
    delta: np.ndarray
    fz: np.ndarray  # (n, 4)
    fx_front: np.ndarray
    fx_rear: np.ndarray
    resist: np.ndarray
    clipped: np.ndarray


def _kinematics(
    vehicle: Vehicle, tyre: TyreSpec, mu: float, v, a, ay, grade, dt: float
) -> _Kinematics:
    m, lr, wb = (
        vehicle.mass_kg,
        vehicle.cog_to_rear_axle_m,
        vehicle.wheelbase_m,
    )
    g = GRAVITY_MPS2
    moving = v > MIN_SLIP_SPEED_MPS
    v_safe = np.where(moving, v, 1.0)
    yaw = np.where(moving, ay / v_safe, 0.0)
    yaw_acc = np.gradient(yaw, dt)
    curvature = np.where(moving, ay / np.maximum(v_safe, 1.0) ** 2, 0.0)
    # Axle loads first with a_x = dV/dt (v_y is a small correction to it); a_y moves load
    # between the wheels of an axle, not between the axles.
    fz = wheel_loads_np(vehicle, a + g * np.sin(grade), ay) * np.cos(grade)[:, None]
    fz_f, fz_r = fz[:, 0] + fz[:, 1], fz[:, 2] + fz[:, 3]
    vy, lateral = _sideslip(vehicle, tyre, mu, v, yaw, yaw_acc, ay, fz_r, dt)
    fz = wheel_loads_np(vehicle, a + g * np.sin(grade), lateral) * np.cos(grade)[:, None]
    # (4.23b, c): front body-lateral force from the yaw moment balance, rear from the lateral one.
    front_lat = (vehicle.yaw_inertia_kgm2 * yaw_acc + lr * m * lateral) / wb
    rear_lat = m * lateral - front_lat
    lim = MAX_UTILISATION * mu
    clipped = (np.abs(front_lat / fz_f) > lim) | (np.abs(rear_lat / fz_r) > lim)
    tan_af = brush_inverse_np(np.clip(front_lat / fz_f, -lim, lim), tyre.c_y_per_rad, mu)
    tan_ar = np.where(moving, (yaw * lr - vy) / v_safe, 0.0)
    delta = curvature * wb + np.arctan(tan_af) - np.arctan(tan_ar)
    ax = a - yaw * vy
    resist = (
        0.5 * AIR_DENSITY_KGPM3 * vehicle.drag_area_m2 * v * np.abs(v)
        + vehicle.rolling_resistance * m * g * np.cos(grade) * (v > 0.01)
        + m * g * np.sin(grade)
    )
    c, t = np.cos(delta), np.tan(delta)
    # (4.23a): F_x2 + F_x1 c − F_y1 s = m a_x + resist, with F_y1 = (G − F_x1 s)/c, gives
    # F_x2 + F_x1 / c = m a_x + resist + G tan δ.
    total = m * ax + resist + front_lat * t
    share = vehicle.traction_front_share
    engine = np.clip(total, -ENGINE_BRAKE_SHARE * m * g, 0.0)
    brake = np.minimum(total - engine, 0.0)
    traction = np.maximum(total, 0.0)
    load_share = fz_f / (fz_f + fz_r)
    front_body = share * (traction + engine) + load_share * brake
    fx_front = front_body * c
    fx_rear = total - front_body
    return _Kinematics(ax, lateral, vy, yaw, delta, fz, fx_front, fx_rear, resist, clipped)


def _sideslip(vehicle: Vehicle, tyre: TyreSpec, mu: float, v, yaw, yaw_acc, ay, fz_r, dt: float):
    """Lateral velocity v_y and body lateral acceleration V ψ̇ + v̇_y of a planned path [m/s, m/s²].

    The path fixes the yaw rate ψ̇ = a_y / V. The rear axle's slip angle, tan α_r = (l_r ψ̇ − v_y)/V,
    gives its force through the brush curve, and with the yaw moment balance (eq. 4.23b, c) the
    body's lateral acceleration a = (F_r + J_z ψ̈ / L) L / (m l_f) = V ψ̇ + v̇_y: a first-order
    equation in v_y. It relaxes to the quasi-static v_y (the one with v̇_y = 0) with the time
    constant τ = V m l_f / (L F_z,r ∂ρ/∂tan α), a few hundredths of a second, shorter than a log's
    sample interval at low speed; so it is integrated exactly over each interval for the local τ
    and a target linear in time (first-order hold), never by explicit steps.
    """
    m, lf, lr, wb = (
        vehicle.mass_kg,
        vehicle.cog_to_front_axle_m,
        vehicle.cog_to_rear_axle_m,
        vehicle.wheelbase_m,
    )
    c, lim = tyre.c_y_per_rad, MAX_UTILISATION * mu
    moving = v > MIN_SLIP_SPEED_MPS
    v_safe = np.where(moving, v, 1.0)
    rear_qs = m * ay * lf / wb - vehicle.yaw_inertia_kgm2 * yaw_acc / wb
    tan_qs = brush_inverse_np(np.clip(rear_qs / fz_r, -lim, lim), c, mu)
    target = np.where(moving, yaw * lr - v * tan_qs, 0.0)
    # brush slope ∂ρ/∂tan α = c (1 − |u|)², u = c tan α / (3 μ); floored near the peak
    u = np.minimum(np.abs(c * tan_qs / (3.0 * mu)), 1.0)
    slope = c * np.maximum((1.0 - u) ** 2, 0.05)
    tau = np.where(moving, v_safe * m * lf / (wb * fz_r * slope), 0.0)
    ratio = tau[:-1] / dt
    decay = np.exp(-1.0 / np.maximum(ratio, 1e-12))
    step = target[1:] - target[:-1]
    offset = target[1:] - decay * target[:-1] - step * ratio * (1.0 - decay)
    vy = _affine_scan(decay, offset, float(target[0]))
    tan_ar = np.where(moving, (yaw * lr - vy) / v_safe, 0.0)
    rear = brush_force_np(tan_ar, c, mu) * fz_r
    lateral = np.where(moving, (rear + vehicle.yaw_inertia_kgm2 * yaw_acc / wb) * wb / (m * lf), ay)
    return vy, lateral


def _affine_scan(decay: np.ndarray, offset: np.ndarray, first: float) -> np.ndarray:
    """y_0 = first, y_{k+1} = decay_k y_k + offset_k, for all k at once (log-depth scan).

    Examples
    --------
    >>> _affine_scan(np.array([0.5, 0.5, 2.0]), np.array([1.0, 0.0, -1.0]), 4.0).tolist()
    [4.0, 3.0, 1.5, 2.0]
    """
    a = np.concatenate([[0.0], decay])
    b = np.concatenate([[first], offset])
    shift = 1
    while shift < a.size:
        b[shift:] = a[shift:] * b[:-shift] + b[shift:]
        a[shift:] = a[shift:] * a[:-shift]
        shift *= 2
    return b


def _wheel_rho(kin: _Kinematics) -> np.ndarray:
    """Per-wheel normalised forces: each axle's force shared equally by its two wheels."""
    fx = np.stack([kin.fx_front / 2, kin.fx_front / 2, kin.fx_rear / 2, kin.fx_rear / 2], axis=-1)
    return fx / kin.fz
