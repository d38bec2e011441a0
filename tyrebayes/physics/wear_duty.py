"""Synthetic duty cycles for wear predictions: speed, axle forces and loads, friction work.

A duty profile (:class:`DutyProfile`) is a model of how a car is driven: an Ornstein-Uhlenbeck
acceleration wish pulled back to a mean speed, the force balance of
:mod:`tyrebayes.physics.vehicle` and the thesis' closed thermal loop (Fig. 4.2) per axle. It is
what :func:`duty_kernel` integrates to the friction-work kernel of a distance at an ambient
temperature, the input of :func:`tyrebayes.inference.wear.predict_wear_volume` and of
``tyrebayes predict-wear``; :mod:`tyrebayes.simulate.wear` drives its synthetic tyre sets with
the same functions (with a known abrasability). Pure JAX; the vehicle is always given.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, PRNGKeyArray

from ..internal.validation import check_in_range, check_positive
from .thermal import StiffnessTemperature, ThermalParams
from .vehicle import Vehicle, aero_drag, axle_loads, rolling_resistance_force
from .wear import (
    TEMPERATURE_GRID_C,
    Abrasability,
    DriveWork,
    abrasability_at_temperature,
    bin_by_temperature,
    simulate_constant_traction,
    slip_work_kernel,
)


class DutyProfile(eqx.Module):
    """A simple random driving profile (all fields scalars; see the module docstring).

    Parameters
    ----------
    mean_speed_mps : float
        Speed the driver returns to [m/s] (mixed driving ~ 60 km/h, motorway ~ 110 km/h).
    speed_sd_mps : float
        Spread of the speed around its mean [m/s].
    accel_sd_mps2 : float
        Standard deviation of the longitudinal acceleration [m/s^2] (calm 0.3, brisk 0.8).
    accel_time_constant_s : float
        Correlation time of the acceleration [s].
    drive_duration_s : float
        Length of one drive [s].
    dt_s : float
        Sample interval of the synthetic drive [s].
    brake_front_fraction : float
        Share of braking force on the front axle [-] (~0.7 for cars).
    """

    mean_speed_mps: float = 60 / 3.6
    speed_sd_mps: float = 5.0
    accel_sd_mps2: float = 0.5
    accel_time_constant_s: float = 4.0
    drive_duration_s: float = 1800.0
    dt_s: float = 2.0
    brake_front_fraction: float = 0.7

    def __check_init__(self):
        for name in ("mean_speed_mps", "accel_time_constant_s", "drive_duration_s", "dt_s"):
            check_positive("DutyProfile", name, getattr(self, name))
        check_in_range("DutyProfile", "speed_sd_mps", self.speed_sd_mps, 0.0, 100.0)
        check_in_range("DutyProfile", "accel_sd_mps2", self.accel_sd_mps2, 0.0, 5.0)
        check_in_range("DutyProfile", "brake_front_fraction", self.brake_front_fraction, 0.0, 1.0)

    @property
    def n_steps(self) -> int:
        return int(round(self.drive_duration_s / self.dt_s)) + 1


class DriveSeries(eqx.Module):
    """One drive's samples: ``speed_mps`` (n,), ``rho_x`` (n, 2) and ``fz_n`` (n, 2) per wheel of
    the (front, rear) axle."""

    time_s: Float[Array, "n"]
    speed_mps: Float[Array, "n"]
    rho_x: Float[Array, "n 2"]
    fz_n: Float[Array, "n 2"]


def _driven_share(vehicle: Vehicle) -> float:
    if vehicle.drive == "fwd":
        return 1.0
    if vehicle.drive == "rwd":
        return 0.0
    return float(vehicle.front_drive_fraction)


def duty_series(
    key: PRNGKeyArray,
    profile: DutyProfile,
    vehicle: Vehicle,
    mean_speed_mps: Float[ArrayLike, ""] | None = None,
) -> DriveSeries:
    """One synthetic drive: OU acceleration pulled back to a mean speed; axle forces, loads."""
    n = profile.n_steps
    dt = profile.dt_s
    v_mean = profile.mean_speed_mps if mean_speed_mps is None else mean_speed_mps
    phi = np.exp(-dt / profile.accel_time_constant_s)
    # The driver's acceleration wish is an OU process; a pull -dv / tau_v back to the mean speed
    # keeps the speed from drifting. For tau_v >> tau_a, var(dv) = sd_a^2 tau_a tau_v, so tau_v is
    # chosen to give the requested speed spread.
    sd_a = max(profile.accel_sd_mps2, 1e-9)
    tau_v = max(profile.speed_sd_mps**2 / (sd_a**2 * profile.accel_time_constant_s), 5 * dt)
    noise = jax.random.normal(key, (n,)) * profile.accel_sd_mps2 * np.sqrt(1 - phi**2)

    def step(state, eps):
        wish, dv = state
        accel = wish - dv / tau_v
        return (phi * wish + eps, dv + accel * dt), (accel, dv)

    _, (accel, dv) = jax.lax.scan(step, (jnp.zeros(()), jnp.zeros(())), noise)
    speed = jnp.maximum(v_mean + dv, 1.0)
    # a floor at 1 m/s keeps the slip definition (division by V) meaningful; there the
    # acceleration is set to 0 so no force is applied at the floor.
    accel = jnp.where(v_mean + dv > 1.0, accel, 0.0)
    resistance = aero_drag(vehicle, speed) + rolling_resistance_force(vehicle)
    total = vehicle.mass_kg * accel + resistance
    share = jnp.where(total > 0, _driven_share(vehicle), profile.brake_front_fraction)
    front_axle_n, rear_axle_n = axle_loads(vehicle, accel)
    rho = jnp.stack(
        [share * total / front_axle_n, (1.0 - share) * total / rear_axle_n], axis=-1
    )  # F_axle / 2 per wheel over F_z,axle / 2 per wheel
    fz = jnp.stack([front_axle_n / 2, rear_axle_n / 2], axis=-1)
    time = jnp.arange(n, dtype=float) * dt
    return DriveSeries(time, speed, rho, fz)


def drive_work(
    series: DriveSeries,
    ambient_c: Float[ArrayLike, ""],
    c_xr: Float[ArrayLike, ""],
    abrasability: Abrasability,
    thermal: ThermalParams,
    comp: StiffnessTemperature,
    grid_c: Float[ArrayLike, "b"] = TEMPERATURE_GRID_C,
) -> tuple[Float[Array, "2 b"], Float[Array, "2"], Float[Array, "2"]]:
    """Binned friction-work kernel, true worn volume and mean tyre temperature of one drive.

    The tyre starts at ambient temperature; the thesis' closed loop (Fig. 4.2) runs per axle.
    """
    grid = jnp.asarray(grid_c, dtype=float)
    dt = series.time_s[1] - series.time_s[0]

    def per_axle(rho, fz):
        run = simulate_constant_traction(
            thermal, comp, c_xr, rho, fz, series.speed_mps, ambient_c, series.time_s
        )
        gamma = abrasability_at_temperature(abrasability, run.tyre_temperature_c)
        volume = jnp.sum(gamma * run.energy_rate_w) * dt
        k = slip_work_kernel(rho, fz, series.speed_mps, dt)
        binned = bin_by_temperature(k, run.tyre_temperature_c, grid)
        t_mean = jnp.sum(k * run.tyre_temperature_c) / jnp.maximum(jnp.sum(k), 1e-12)
        return binned, volume, t_mean

    return jax.vmap(per_axle, in_axes=(1, 1))(series.rho_x, series.fz_n)


def duty_drives(
    key: PRNGKeyArray,
    n_drives: int,
    ambient_c: Float[ArrayLike, "d"],
    c_xr: float,
    abrasability: Abrasability,
    profile: DutyProfile,
    vehicle: Vehicle,
    thermal: ThermalParams,
    comp: StiffnessTemperature,
    mean_speed_mps: Float[ArrayLike, "d"] | None = None,
) -> DriveWork:
    """``n_drives`` drives of a duty profile: friction-work kernels and worn volumes (eq. 4.26).

    ``ambient_c`` per drive [°C]; ``c_xr`` the tyres' compensated stiffness; ``abrasability``
    γ(T) of the tyres; ``mean_speed_mps`` per drive (default the profile's).
    """
    ambient = jnp.broadcast_to(jnp.asarray(ambient_c, dtype=float), (n_drives,))
    speeds = (
        jnp.full((n_drives,), profile.mean_speed_mps)
        if mean_speed_mps is None
        else jnp.broadcast_to(jnp.asarray(mean_speed_mps, dtype=float), (n_drives,))
    )
    keys = jax.random.split(key, n_drives)

    @jax.jit
    def one(k, amb, v):
        s = duty_series(k, profile, vehicle, v)
        binned, vol, t_mean = drive_work(s, amb, c_xr, abrasability, thermal, comp)
        dist = jnp.sum(s.speed_mps[:-1]) * profile.dt_s / 1000.0
        return binned, vol, t_mean, dist

    binned, vol, t_mean, dist = jax.lax.map(lambda a: one(*a), (keys, ambient, speeds))
    return DriveWork(dist, ambient, binned, jnp.asarray(TEMPERATURE_GRID_C), vol, t_mean)


def duty_kernel(
    key: PRNGKeyArray,
    ambient_c: float,
    km: float,
    profile: DutyProfile,
    vehicle: Vehicle,
    c_xr: float = 40.0,
    n_drives: int = 20,
    thermal: ThermalParams | None = None,
    comp: StiffnessTemperature | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Binned friction-work kernel (2 axles, bins) of ``km`` kilometres of a profile at an ambient.

    Averages ``n_drives`` drives and scales to ``km``; feed it to
    :func:`tyrebayes.inference.wear.predict_wear_volume`. ``c_xr`` only sets the (tiny) friction
    heating of the tyre temperature. Returns ``(kernel [J], grid_c [°C])``.
    """
    thermal = ThermalParams() if thermal is None else thermal
    comp = StiffnessTemperature() if comp is None else comp
    work = duty_drives(
        key,
        n_drives,
        jnp.full((n_drives,), float(ambient_c)),
        c_xr,
        Abrasability(1.0),
        profile,
        vehicle,
        thermal,
        comp,
    )
    scale = km / float(jnp.sum(work.distance_km))
    return np.asarray(work.kernel_binned.sum(axis=0)) * scale, np.asarray(work.grid_c)
