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

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, PRNGKeyArray

from .._domain import load_vehicle
from ..physics.thermal import StiffnessTemperature, ThermalParams
from ..physics.vehicle import Vehicle
from ..physics.wear import (
    Abrasability,
    DriveWork,
    TreadGeometry,
    WearObservations,
    cumulative_depth_loss,
)
from ..physics.wear_duty import DriveSeries as DriveSeries
from ..physics.wear_duty import DutyProfile as DutyProfile
from ..physics.wear_duty import drive_work as drive_work
from ..physics.wear_duty import duty_drives, duty_kernel


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
    return duty_drives(
        key,
        n_drives,
        ambient_c,
        c_xr,
        abrasability,
        profile,
        vehicle,
        thermal,
        comp,
        mean_speed_mps,
    )


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
    profile = DutyProfile() if profile is None else profile
    vehicle = load_vehicle("compact_fwd") if vehicle is None else vehicle
    return duty_kernel(key, ambient_c, km, profile, vehicle, c_xr, n_drives, thermal, comp)
