"""Vehicle parameters, the single-track model (thesis eq. 4.22/4.23) and wheel loads.

Axes: x forward, y left, z up; yaw positive to the left. Axle 1 is the front, 2 the rear (thesis
notation). Accelerations a_x, a_y are body-frame accelerations of the centre of gravity.
"""

from __future__ import annotations

from collections.abc import Mapping

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..internal.validation import check_in_range, check_nonnegative, check_positive

GRAVITY_MPS2 = 9.80665
AIR_DENSITY_KGPM3 = 1.2  # at about 20 °C, sea level

Batch = Float[ArrayLike, "..."]
# A vehicle parameter: a number, or an array when a batch of vehicles is vmapped over.
Param = Float[ArrayLike, "..."]

_DRIVES = ("fwd", "rwd", "awd")
_REQUIRED_KEYS = (
    "mass_kg",
    "wheelbase_m",
    "cog_to_front_axle_m",
    "cog_height_m",
    "yaw_inertia_kgm2",
    "track_width_m",
    "wheel_radius_m",
    "drive",
    "steering_ratio",
)

# What a road vehicle of the classes the package models (cars, SUVs, vans) can have; a vehicle file
# outside these is a unit or typing mistake (1.7e6 kg, a radius in mm), not an unusual car. Mass:
# a quadricycle with driver ~400 kg to a loaded 3.5 t van's 10 t upper bound of light trucks;
# wheel radius: 13" city-car tyres (0.26 m) to light-truck tyres (0.45 m), with margin.
_PLAUSIBLE = {
    "mass_kg": (300.0, 10_000.0),
    "wheelbase_m": (1.5, 6.0),
    "cog_height_m": (0.2, 2.0),
    "yaw_inertia_kgm2": (100.0, 100_000.0),
    "track_width_m": (0.8, 2.6),
    "wheel_radius_m": (0.15, 0.7),
    "steering_ratio": (5.0, 30.0),
    "drag_area_m2": (0.0, 10.0),
    "rolling_resistance": (0.0, 0.05),
    "width_m": (1.0, 3.0),
}


class Vehicle(eqx.Module):
    """Vehicle parameters in the DESIGN.md vehicle-file contract.

    Parameters
    ----------
    mass_kg : float
        Mass m including driver [kg].
    wheelbase_m : float
        Wheelbase L = l_f + l_r [m].
    cog_to_front_axle_m : float
        l_f, centre of gravity to front axle [m], 0 < l_f < L.
    cog_height_m : float
        Height h of the centre of gravity [m].
    yaw_inertia_kgm2 : float
        J_z [kg m²].
    track_width_m : float
        Track width t (same front and rear) [m].
    wheel_radius_m : float
        Nominal rolling radius R_e [m].
    drive : str
        ``"fwd"``, ``"rwd"`` or ``"awd"`` (static).
    steering_ratio : float
        Steering-wheel angle / road-wheel angle [-].
    drag_area_m2 : float
        C_d·A [m²].
    rolling_resistance : float
        Rolling-resistance coefficient f_rr [-].
    width_m : float
        Body width [m] (ISO 3888-2 lane widths, cone strikes).
    front_drive_fraction : float
        Share of the traction force on the front axle for ``"awd"`` [-].
    pitch_gradient_rad_per_mps2 : float
        Body pitch per unit longitudinal acceleration, squat and dive of the suspension
        [rad/(m/s²)], nose-up positive for positive a_x. A body-fixed IMU then reads
        a_x (1 + g·k) (see :func:`body_pitch_gain`). Passenger cars pitch about 1°/g, i.e.
        k ≈ 0.002, the default.

    Notes
    -----
    Numeric fields may be arrays of one shape: a batch of vehicles for ``eqx.filter_vmap``
    (``drive`` is static and shared by the batch).

    Examples
    --------
    >>> from tyrebayes import load_vehicle
    >>> car = load_vehicle("compact_fwd")
    >>> car.drive, car.driven_axle, round(float(car.cog_to_rear_axle_m), 3)
    ('fwd', 'front', 1.643)
    """

    mass_kg: Param
    wheelbase_m: Param
    cog_to_front_axle_m: Param
    cog_height_m: Param
    yaw_inertia_kgm2: Param
    track_width_m: Param
    wheel_radius_m: Param
    drive: str = eqx.field(static=True)
    steering_ratio: Param
    drag_area_m2: Param = 0.7
    rolling_resistance: Param = 0.011
    width_m: Param = 1.80
    front_drive_fraction: Param = 0.5
    pitch_gradient_rad_per_mps2: Param = 0.002

    def __check_init__(self):
        for name in (
            "mass_kg",
            "wheelbase_m",
            "cog_to_front_axle_m",
            "cog_height_m",
            "yaw_inertia_kgm2",
            "track_width_m",
            "wheel_radius_m",
            "steering_ratio",
            "width_m",
        ):
            check_positive("Vehicle", name, getattr(self, name))
        check_nonnegative("Vehicle", "drag_area_m2", self.drag_area_m2)
        check_nonnegative("Vehicle", "rolling_resistance", self.rolling_resistance)
        check_in_range(
            "Vehicle", "pitch_gradient_rad_per_mps2", self.pitch_gradient_rad_per_mps2, 0.0, 0.02
        )
        check_in_range("Vehicle", "front_drive_fraction", self.front_drive_fraction, 0.0, 1.0)
        if self.drive not in _DRIVES:
            raise ValueError(f"Vehicle.drive: expected one of {_DRIVES}, got {self.drive!r}")
        check_in_range(
            "Vehicle", "cog_to_front_axle_m", self.cog_to_front_axle_m, 1e-6, self.wheelbase_m
        )

    @property
    def cog_to_rear_axle_m(self) -> Param:
        """l_r = L − l_f [m]."""
        return self.wheelbase_m - self.cog_to_front_axle_m

    @property
    def driven_axle(self) -> str:
        """``"front"``, ``"rear"`` or ``"both"``."""
        return {"fwd": "front", "rwd": "rear", "awd": "both"}[self.drive]

    @property
    def traction_front_share(self) -> Param:
        """Share of the traction force carried by the front axle."""
        return {"fwd": 1.0, "rwd": 0.0, "awd": self.front_drive_fraction}[self.drive]


def vehicle_from_mapping(data: Mapping, source: str = "vehicle") -> Vehicle:
    """A :class:`Vehicle` from the keys of a vehicle file (DESIGN.md contract), checked.

    Reading the file is :func:`tyrebayes._domain.load_vehicle`'s job; this function only checks
    the keys and values (physics reads no files).

    Raises
    ------
    ValueError
        If a required key is missing, a key is unknown, or a value is invalid or outside what a
        road car can have (e.g. a mass over 10 t); the message names ``source``, the key and the
        value.

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> load_vehicle("compact_fwd").drive
    'fwd'
    """
    missing = [k for k in _REQUIRED_KEYS if k not in data]
    if missing:
        raise ValueError(f"{source}: missing key {missing[0]!r}")
    known = set(Vehicle.__dataclass_fields__)
    unknown = sorted(set(data) - known - {"name", "description"})
    if unknown:
        raise ValueError(f"{source}: unknown key {unknown[0]!r}")
    fields = {k: v for k, v in data.items() if k in known}
    for key, value in fields.items():
        if key != "drive" and not isinstance(value, int | float):
            raise ValueError(f"{source}: {key} must be a number, got {value!r}")
    fields = {k: (v if k == "drive" else float(v)) for k, v in fields.items()}
    for key, (lo, hi) in _PLAUSIBLE.items():
        if key in fields and not lo <= fields[key] <= hi:
            raise ValueError(
                f"{source}: {key}: expected a road car's value in [{lo:g}, {hi:g}], got "
                f"{fields[key]}"
            )
    return Vehicle(**fields)


def body_pitch_gain(vehicle: Vehicle) -> Param:
    """Factor 1 + g·k by which a body-fixed IMU over-reads a_x as the body pitches [-].

    The body pitches by k·a_x (squat under traction, dive under braking, both nose-up for
    positive a_x), so the IMU's x axis picks up g·sin(k·a_x) ≈ g·k·a_x of gravity on top of a_x.
    A fixed mounting pitch adds a constant instead, which the offset estimate removes.

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> round(float(body_pitch_gain(load_vehicle("compact_fwd"))), 4)
    1.0196
    """
    return 1.0 + GRAVITY_MPS2 * vehicle.pitch_gradient_rad_per_mps2


def axle_loads(vehicle: Vehicle, ax: Batch) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """Front and rear axle loads with longitudinal load transfer m a_x h / L [N].

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> v = load_vehicle("compact_fwd")
    >>> front, rear = axle_loads(v, 0.0)
    >>> round(float(front + rear) / v.mass_kg, 5)
    9.80665
    """
    ax = jnp.asarray(ax)
    weight = vehicle.mass_kg * GRAVITY_MPS2
    transfer = vehicle.mass_kg * ax * vehicle.cog_height_m / vehicle.wheelbase_m
    front = weight * vehicle.cog_to_rear_axle_m / vehicle.wheelbase_m - transfer
    rear = weight * vehicle.cog_to_front_axle_m / vehicle.wheelbase_m + transfer
    return front, rear


def wheel_loads(vehicle: Vehicle, ax: Batch, ay: Batch) -> Float[Array, "... 4"]:
    """Wheel loads (fl, fr, rl, rr) [N] with longitudinal and lateral load transfer.

    Rigid body without roll-stiffness distribution: the lateral transfer m a_y h / t is shared by
    the axles in proportion to their static loads; positive a_y (turning left) loads the right
    wheels. The loads always sum to m g.
    """
    ax, ay = jnp.broadcast_arrays(jnp.asarray(ax, dtype=float), jnp.asarray(ay, dtype=float))
    front, rear = axle_loads(vehicle, ax)
    lateral = vehicle.mass_kg * ay * vehicle.cog_height_m / vehicle.track_width_m
    front_share = vehicle.cog_to_rear_axle_m / vehicle.wheelbase_m
    d_front = lateral * front_share
    d_rear = lateral * (1.0 - front_share)
    return jnp.stack(
        [front / 2 - d_front, front / 2 + d_front, rear / 2 - d_rear, rear / 2 + d_rear], axis=-1
    )


def static_wheel_loads(vehicle: Vehicle) -> Float[Array, "4"]:
    """Static wheel loads (fl, fr, rl, rr) [N].

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> round(float(static_wheel_loads(load_vehicle("compact_fwd"))[0]))
    4865
    """
    return wheel_loads(vehicle, 0.0, 0.0)


def aero_drag(vehicle: Vehicle, speed_mps: Batch) -> Float[Array, "..."]:
    """Aerodynamic drag ½ ρ_air C_d A V² [N]."""
    speed = jnp.asarray(speed_mps)
    return 0.5 * AIR_DENSITY_KGPM3 * vehicle.drag_area_m2 * speed * jnp.abs(speed)


def rolling_resistance_force(vehicle: Vehicle, grade_rad: Batch = 0.0) -> Float[Array, "..."]:
    """Total rolling resistance f_rr m g cos(grade) of the four tyres [N]."""
    return vehicle.rolling_resistance * vehicle.mass_kg * GRAVITY_MPS2 * jnp.cos(grade_rad)


class SingleTrackState(eqx.Module):
    """Planar state of the single-track model (or its time derivative).

    Fields are body-frame longitudinal speed v_x [m/s], lateral speed v_y [m/s] and yaw rate ψ̇
    [rad/s].
    """

    vx_mps: Float[ArrayLike, "..."]
    vy_mps: Float[ArrayLike, "..."]
    yaw_rate_radps: Float[ArrayLike, "..."]


def single_track_accelerations(
    vehicle: Vehicle,
    steer_rad: Batch,
    fx_front: Batch,
    fy_front: Batch,
    fx_rear: Batch,
    fy_rear: Batch,
) -> tuple[Float[Array, "..."], Float[Array, "..."], Float[Array, "..."]]:
    """Body accelerations from the axle forces, thesis eq. 4.23 (β = 0, no drag).

    Returns
    -------
    (ax, ay, yaw_acc)
        a_x, a_y [m/s²] and ψ̈ [rad/s²].
    """
    c, s = jnp.cos(steer_rad), jnp.sin(steer_rad)
    m, lf, lr = vehicle.mass_kg, vehicle.cog_to_front_axle_m, vehicle.cog_to_rear_axle_m
    ax = (fx_rear + fx_front * c - fy_front * s) / m  # (4.23a)
    ay = (fy_rear + fx_front * s + fy_front * c) / m  # (4.23b)
    yaw_acc = (
        lf * (fy_front * c + fx_front * s) - lr * fy_rear
    ) / vehicle.yaw_inertia_kgm2  # (4.23c)
    return ax, ay, yaw_acc


def single_track_derivatives(
    vehicle: Vehicle,
    state: SingleTrackState,
    steer_rad: Batch,
    fx_front: Batch,
    fy_front: Batch,
    fx_rear: Batch,
    fy_rear: Batch,
) -> SingleTrackState:
    """Forward dynamics: time derivative of (v_x, v_y, ψ̇) (eq. 4.22 in body coordinates).

    a_x = v̇_x − ψ̇ v_y and a_y = v̇_y + ψ̇ v_x, with a_x, a_y, ψ̈ from
    :func:`single_track_accelerations`.
    """
    ax, ay, yaw_acc = single_track_accelerations(
        vehicle, steer_rad, fx_front, fy_front, fx_rear, fy_rear
    )
    return SingleTrackState(
        vx_mps=ax + state.yaw_rate_radps * state.vy_mps,
        vy_mps=ay - state.yaw_rate_radps * state.vx_mps,
        yaw_rate_radps=yaw_acc,
    )


def single_track_inverse(
    vehicle: Vehicle,
    ax: Batch,
    ay: Batch,
    yaw_acc: Batch,
    steer_rad: Batch,
    resistance_n: Batch = 0.0,
) -> tuple[Float[Array, "..."], Float[Array, "..."], Float[Array, "..."], Float[Array, "..."]]:
    """Axle forces from measured motion: eq. 4.23 solved for (F_x1, F_y1, F_x2, F_y2).

    Three equations, four unknowns: the drive closes the system. The traction force is split
    between the axles by :attr:`Vehicle.traction_front_share` (the non-driven axle carries no
    longitudinal force; its rolling resistance is part of ``resistance_n``).

    Parameters
    ----------
    ax, ay, yaw_acc : array_like
        Body accelerations [m/s²] and yaw acceleration [rad/s²].
    steer_rad : array_like
        Front road-wheel angle δ_1 [rad].
    resistance_n : array_like
        Forces the tyres must overcome besides inertia: aerodynamic drag, rolling resistance and
        the grade component m g sin(θ) [N].

    Returns
    -------
    (fx_front, fy_front, fx_rear, fy_rear)
        Axle forces in the wheel frames [N].

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> v = load_vehicle("compact_fwd")
    >>> fx1, fy1, fx2, fy2 = single_track_inverse(v, 1.0, 0.0, 0.0, 0.0)
    >>> round(float(fx1)), round(float(fx2))
    (1600, 0)
    """
    c, s = jnp.cos(steer_rad), jnp.sin(steer_rad)
    m, lr, wheelbase = vehicle.mass_kg, vehicle.cog_to_rear_axle_m, vehicle.wheelbase_m
    longitudinal = m * jnp.asarray(ax) + resistance_n  # X = F_x2 + F_x1 c − F_y1 s
    # (4.23b, c): the front axle's body-lateral force G = F_x1 s + F_y1 c follows from the moment
    # balance, and the rear lateral force from the lateral balance.
    front_lateral = (vehicle.yaw_inertia_kgm2 * jnp.asarray(yaw_acc) + lr * m * jnp.asarray(ay)) / (
        wheelbase
    )
    fy_rear = m * jnp.asarray(ay) - front_lateral
    # Traction T split F_x1 = φ T, F_x2 = (1 − φ) T with φ the front share; then (4.23a) and the
    # front lateral balance are a 2×2 system in (T, F_y1):
    #   ((1 − φ) + φ c) T − s F_y1 = X,   φ s T + c F_y1 = G,   det = (1 − φ) c + φ > 0.
    # One formula for every drive, so φ may be a traced array (no Python branch on its value).
    share = jnp.asarray(vehicle.traction_front_share)
    a = (1.0 - share) + share * c
    det = (1.0 - share) * c + share
    traction = (longitudinal * c + s * front_lateral) / det
    fy_front = (a * front_lateral - share * s * longitudinal) / det
    fx_front = share * traction
    fx_rear = (1.0 - share) * traction
    return fx_front, fy_front, fx_rear, fy_rear
