"""Synthetic tread-wear data from a known abrasability gamma: drives, tread depths, radius drift.

Generative model (per drive *d*, axle *a* in (front, rear), one wheel of that axle)::

    speed, acceleration      smooth random duty profile (Ornstein-Uhlenbeck acceleration)
    F_total = m a + drag + rolling resistance          split: traction -> driven axle,
                                                       braking -> ``brake_front_fraction`` front
    rho_x   = F_axle / 2 / F_z,wheel (load transfer m a h / L included)
    T(t)    = lumped tyre temperature (physics.thermal) with rolling loss + friction power
    C_x(t)  = C_xr exp(-beta (T - 20))                 (physics.thermal compensation)
    V_d,a   = sum_t gamma(T_t) rho_t^2 F_z V_t dt / C_x(t)    [mm^3]   (thesis eq. 4.26 + 4.27)

Observations:

* tread depth of each axle at given odometer readings, ``depth = d0 - V_cum / A_wear + noise``;
* per drive, the relative rolling-radius difference driven - non-driven axle that the wheel speeds
  reveal, ``r_d = offset - lambda (loss_front - loss_rear) / R_0 + noise``.

Volume -> depth (:class:`TreadGeometry`, assumptions stated): the whole tread band wears, area
``A_wear = 2 pi R w (1 - void)``; 205/55R16: R = 316 mm, tread width 160 mm, groove void 30 %;
rubber density 1.15 g/cm^3; the rolling radius shrinks by ``lambda = 1`` times the worn depth
(the rubber lost is outside the belt). Scale check: ADAC's 59-172 g per 1000 km per car set
(``tyrebayes/data/wear_by_tyre_type.csv``) is 15-43 g per tyre, 0.04-0.12 mm per 1000 km.

Only longitudinal slip work is simulated (the thesis' eq. 4.24, alpha = 0); cornering work would
add to both axles and is absorbed into gamma.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, PRNGKeyArray

from .._domain import load_vehicle
from ..internal.validation import check_in_range, check_positive
from ..physics.thermal import StiffnessTemperature, ThermalParams
from ..physics.vehicle import Vehicle, aero_drag, axle_loads, rolling_resistance_force
from ..physics.wear import (
    TEMPERATURE_GRID_C,
    Abrasability,
    DriveWork,
    TreadGeometry,
    WearObservations,
    abrasability_at_temperature,
    bin_by_temperature,
    cumulative_depth_loss,
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


def simulate_drive_series(
    key: PRNGKeyArray,
    profile: DutyProfile,
    vehicle: Vehicle,
    mean_speed_mps: Float[ArrayLike, ""] | None = None,
) -> DriveSeries:
    """One synthetic drive: OU acceleration, speed pulled back to its mean, axle forces and loads.

    Examples
    --------
    >>> d = simulate_drive_series(jax.random.PRNGKey(0), DutyProfile(), load_vehicle("compact_fwd"))
    >>> d.rho_x.shape
    (901, 2)
    """
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


def simulate_drives(
    key: PRNGKeyArray,
    n_drives: int,
    ambient_c: Float[ArrayLike, "d"],
    c_xr: float,
    abrasability: Abrasability,
    profile: DutyProfile | None = None,
    vehicle: Vehicle | None = None,
    thermal: ThermalParams | None = None,
    comp: StiffnessTemperature | None = None,
    mean_speed_mps: Float[ArrayLike, "d"] | None = None,
) -> DriveWork:
    """Simulate ``n_drives`` drives of one car (one tyre set) and their friction work and wear.

    Parameters
    ----------
    key : PRNGKey
    n_drives : int
    ambient_c : Array (n_drives,)
        Ambient temperature of each drive [°C].
    c_xr : float
        True compensated stiffness of the tyres [-].
    abrasability : Abrasability
        True gamma(T) of the tyres.
    profile, vehicle, thermal, comp : optional
        Defaults: ``DutyProfile()``, ``load_vehicle("compact_fwd")``, ``ThermalParams()``,
        ``StiffnessTemperature()``.
    mean_speed_mps : Array (n_drives,), optional
        Per-drive mean speed (mixes urban and motorway drives); default the profile's.

    Examples
    --------
    >>> w = simulate_drives(jax.random.PRNGKey(1), 3, jnp.full(3, 15.0), 40.0, Abrasability(0.02))
    >>> w.volume_mm3.shape
    (3, 2)
    """
    profile = DutyProfile() if profile is None else profile
    vehicle = load_vehicle("compact_fwd") if vehicle is None else vehicle
    thermal = ThermalParams() if thermal is None else thermal
    comp = StiffnessTemperature() if comp is None else comp
    ambient = jnp.broadcast_to(jnp.asarray(ambient_c, dtype=float), (n_drives,))
    speeds = (
        jnp.full((n_drives,), profile.mean_speed_mps)
        if mean_speed_mps is None
        else jnp.broadcast_to(jnp.asarray(mean_speed_mps, dtype=float), (n_drives,))
    )
    keys = jax.random.split(key, n_drives)

    @jax.jit
    def one(k, amb, v):
        s = simulate_drive_series(k, profile, vehicle, v)
        binned, vol, t_mean = drive_work(s, amb, c_xr, abrasability, thermal, comp)
        dist = jnp.sum(s.speed_mps[:-1]) * profile.dt_s / 1000.0
        return binned, vol, t_mean, dist

    binned, vol, t_mean, dist = jax.lax.map(lambda a: one(*a), (keys, ambient, speeds))
    return DriveWork(dist, ambient, binned, jnp.asarray(TEMPERATURE_GRID_C), vol, t_mean)


def seasonal_ambient(
    key: PRNGKeyArray,
    day_of_year: Float[ArrayLike, "d"],
    mean_c: float = 10.0,
    amplitude_c: float = 9.0,
    noise_c: float = 3.0,
) -> Float[Array, "d"]:
    """Ambient temperature of a temperate climate: annual cosine (peak ~ 20 July) + daily noise.

    Defaults resemble central Germany (annual mean ~10 °C, July ~19 °C, January ~1 °C).
    """
    day = jnp.asarray(day_of_year, dtype=float)
    base = mean_c + amplitude_c * jnp.cos(2 * jnp.pi * (day - 200.0) / 365.0)
    return base + noise_c * jax.random.normal(key, day.shape)


def observe_wear(
    key: PRNGKeyArray,
    work: DriveWork,
    reading_km: Float[ArrayLike, "m"],
    depth_noise_mm: float = 0.2,
    radius_noise: float = 3e-4,
    radius_offset: float = 0.0,
    initial_depth_mm: tuple[float, float] = (8.0, 8.0),
    geom: TreadGeometry | None = None,
) -> WearObservations:
    """Tread-depth readings (both axles) at odometer readings and per-drive radius drift.

    A reading at ``reading_km`` is taken after the last drive that ends at or before it.
    """
    geom = TreadGeometry() if geom is None else geom
    k1, k2 = jax.random.split(key)
    loss = cumulative_depth_loss(work.volume_mm3, geom)
    odometer = np.concatenate([[0.0], np.cumsum(np.asarray(work.distance_km))])
    idx = np.searchsorted(odometer, np.asarray(reading_km, dtype=float), side="right") - 1
    idx = np.clip(idx, 0, len(odometer) - 1)
    drive_index = np.repeat(idx, 2)
    axle = np.tile([0, 1], len(idx))
    d0 = np.asarray(initial_depth_mm)[axle]
    depth = d0 - loss[drive_index, axle] + depth_noise_mm * jax.random.normal(k1, (len(axle),))
    drift = (
        radius_offset
        - geom.radius_per_depth * (loss[1:, 0] - loss[1:, 1]) / geom.outer_radius_mm
        + radius_noise * jax.random.normal(k2, (loss.shape[0] - 1,))
    )
    return WearObservations(
        jnp.asarray(drive_index), jnp.asarray(axle), depth, drift, depth_noise_mm, radius_noise
    )


def profile_kernel(
    key: PRNGKeyArray,
    ambient_c: float,
    km: float = 1000.0,
    profile: DutyProfile | None = None,
    c_xr: float = 40.0,
    n_drives: int = 20,
    vehicle: Vehicle | None = None,
    thermal: ThermalParams | None = None,
    comp: StiffnessTemperature | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Binned friction-work kernel (2 axles, bins) of ``km`` kilometres of a profile at an ambient.

    Averages ``n_drives`` synthetic drives and scales to ``km``; feed it to
    :func:`tyrebayes.inference.wear.predict_wear_volume`. ``c_xr`` only sets the (tiny) friction
    heating of the tyre temperature.
    """
    work = simulate_drives(
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
