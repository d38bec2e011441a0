"""A year of one car's drives whose tyres wear with a known γ and κ, written as stream files.

Each logged drive (:func:`~tyrebayes.simulate.drive.simulate_drive`, short and at a low rate to
stay cheap) stands for the distance to the next one, which the stream's extra ``odometer``
column [m] records. Truth per drive and wheel: the tyre's friction work, longitudinal
Σ |ρ_x F_z V σ_x| dt from the simulator's own slip and force (eq. 4.19a) plus lateral
Σ |F_y V_x tan α| dt (eq. 4.19b, :func:`lateral_sliding_power`: the axle's lateral force of the
single-track model, eq. 4.23b, c, and its slip angle from the drive's kinematics, which the
simulator set from the tyre's brush curve with its true c_y and μ), the worn volume
γ Σ exp(κ (T − 20)) w dt with the simulated tyre temperature T (eq. 4.26 with the package's
temperature extension), scaled to the interval's distance and by a log-normal factor
(``representativeness_sd``: the unlogged driving differs from the logged drive). The worn depth
shrinks each tyre's rolling radius one to one, and the next drive's wheel speeds carry it
(``SensorTruth.radius_error``); each tyre also has its own manufacturing radius error
(``radius_spread``), which moves with it. A rotation swaps front and rear tyres on each side; a
replacement mounts four new tyres. Tread-depth readings (per axle, the mean of its two tyres plus
gauge noise) are taken at service intervals. The drives corner (``profile``; by default
:data:`COMMUTE_PROFILE`, whose corners and lane changes do about half of the friction work), and
the free-rolling rear axle of a front-driven car wears almost only laterally.

Examples
--------
>>> import tempfile
>>> with tempfile.TemporaryDirectory() as tmp:
...     truth = simulate_wear_year(0, tmp, n_drives=3, drive_s=60.0)
>>> len(truth.stream_paths)
3
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import NamedTuple

import equinox as eqx
import numpy as np
import pandas as pd

from .._domain import load_vehicle
from ..physics.vehicle import Vehicle
from ..physics.wear import TreadGeometry
from ..streams.io import write_stream
from .drive import MIN_SLIP_SPEED_MPS, seed_sequence, simulate_drive
from .profiles import ProfileOptions
from .sensors import SensorModel, draw_sensor_truth
from .truth import DriveTruth

#: Wheel order (fl, fr, rl, rr) of the tyres after a rotation (front and rear swap per side).
_ROTATED = np.array([2, 3, 0, 1])
#: A commuter's driving: the default profile with 15 corners an hour (a_y 1-4 m/s²) and its lane
#: changes; on the compact car its lateral work is about half of the friction work.
COMMUTE_PROFILE = ProfileOptions(corners_per_hour=15.0)


def lateral_sliding_power(truth: DriveTruth, vehicle: Vehicle) -> np.ndarray:
    """True lateral friction power |F_y V_x tan α| of each axle (n, 2) [W] (eq. 4.19b).

    F_y from the single-track balances (eq. 4.23b, c) with the drive's a_y and yaw acceleration,
    as the simulator set them; the slip angles from its kinematics: tan α_r = (ψ̇ l_r − v_y) / V
    and α_f = δ − ψ̇ L / V + α_r (the simulator chose v_y and δ from the brush lateral curve, so
    these are the tyre's true slip angles). Zero below the simulator's slip speed.

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> car = load_vehicle("compact_fwd")
    >>> _, truth = simulate_drive(2, car, "summer", duration_s=60.0, sample_rate_hz=10.0)
    >>> bool((lateral_sliding_power(truth, car) >= 0).all())
    True
    """
    v, yaw, ay = truth.vx_mps, truth.yaw_rate_radps, truth.ay_mps2
    dt = float(np.median(np.diff(truth.time_s))) if v.size > 1 else 1.0
    # the simulator's yaw acceleration: the gradient on its regular clock
    yaw_acc = np.gradient(yaw, dt) if v.size > 1 else np.zeros_like(yaw)
    lr, wb = vehicle.cog_to_rear_axle_m, vehicle.wheelbase_m
    front = (vehicle.yaw_inertia_kgm2 * yaw_acc + lr * vehicle.mass_kg * ay) / wb
    rear = vehicle.mass_kg * ay - front
    moving = v > MIN_SLIP_SPEED_MPS
    v_safe = np.where(moving, v, 1.0)
    tan_r = np.where(moving, (yaw * lr - truth.vy_mps) / v_safe, 0.0)
    alpha_f = truth.road_wheel_angle_rad - np.where(moving, yaw * wb / v_safe, 0.0)
    tan_f = np.where(moving, np.tan(alpha_f + np.arctan(tan_r)), 0.0)
    return np.column_stack([np.abs(front * v * tan_f), np.abs(rear * v * tan_r)])


class WearYearTruth(eqx.Module):
    """What :func:`simulate_wear_year` made: files, the true parameters and tyre changes.

    ``change_drive_index`` / ``change_type``: the drive at which each change took effect and
    ``"rotation"`` or ``"replacement"``. ``depth_mm[k, i]``: true depth of the tyre on wheel i
    (fl, fr, rl, rr) at the start of drive k. ``drive_work_j[k, a]``: true longitudinal friction
    work of axle a (front, rear) in logged drive k [J]; ``drive_work_y_j[k, a]`` its lateral
    work. ``interval_loss_mm[k, a]``: tread lost by the tyres on axle a (mean of the two) over
    the interval drive k stands for [mm]. ``c_y_per_rad``: the tyres' true cornering stiffness.
    ``readings``: odometer_km, axle, depth_mm.
    """

    stream_paths: tuple[str, ...] = eqx.field(static=True)
    gamma_mm3_per_j: float
    kappa_per_k: float
    change_drive_index: tuple[int, ...] = eqx.field(static=True)
    change_type: tuple[str, ...] = eqx.field(static=True)
    total_km: float
    depth_mm: np.ndarray
    drive_work_j: np.ndarray
    drive_work_y_j: np.ndarray
    interval_loss_mm: np.ndarray
    c_y_per_rad: float
    readings: pd.DataFrame = eqx.field(static=True)

    @property
    def wear_mm_per_1000km(self) -> np.ndarray:
        """True wear rate of each axle position over the year (front, rear) [mm per 1000 km]."""
        return 1000.0 * self.interval_loss_mm.sum(axis=0) / self.total_km


def simulate_wear_year(
    seed: int,
    out_dir: str | os.PathLike,
    *,
    vehicle: str = "compact_fwd",
    tyre: str = "summer",
    n_drives: int = 40,
    drive_s: float = 600.0,
    sample_rate_hz: float = 10.0,
    km_per_year: float = 15000.0,
    gamma_mm3_per_j: float = 0.04,
    kappa_per_k: float = 0.02,
    rotation_at: float | None = 0.45,
    replacement_at: float | None = 0.8,
    representativeness_sd: float = 0.2,
    radius_spread: float = 0.001,
    reading_every_km: float = 5000.0,
    reading_noise_mm: float = 0.2,
    new_depth_mm: float = 8.0,
    geom: TreadGeometry | None = None,
    profile: ProfileOptions | None = None,
) -> WearYearTruth:
    """Simulate and write one year of drives (module docstring); returns the truth.

    ``rotation_at`` / ``replacement_at`` are fractions of the year's drives (None: none).
    ``profile``: the driver (default :data:`COMMUTE_PROFILE`).
    Streams are written as ``drive_000.parquet``, ... into ``out_dir``.
    """
    profile = COMMUTE_PROFILE if profile is None else profile
    geom = TreadGeometry() if geom is None else geom
    law = _WearLaw(gamma_mm3_per_j, kappa_per_k, representativeness_sd, geom.wear_area_mm2)
    car = load_vehicle(vehicle)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed_sequence(seed).spawn(1)[0])
    base = draw_sensor_truth(rng, SensorModel(), car.wheel_radius_m)
    eps = radius_spread * rng.standard_normal(4)  # per tyre, moves with the tyre
    loss = np.zeros(4)  # per tyre [mm]
    on_wheel = np.arange(4)  # tyre index on (fl, fr, rl, rr)
    changes = _change_schedule(n_drives, rotation_at, replacement_at)
    ambient = _ambient_c(rng, n_drives)
    odometer_m = 0.0
    drives, depth_rows, readings, losses = [], [], [], []
    next_reading = reading_every_km
    for k in range(n_drives):
        if k in changes:
            on_wheel, eps, loss = _change_tyres(changes[k], on_wheel, eps, loss, rng, radius_spread)
        depth_rows.append(new_depth_mm - loss[on_wheel])
        radius_error = eps[on_wheel] - loss[on_wheel] / (1000.0 * car.wheel_radius_m)
        drive = _year_drive(
            rng,
            car,
            out / f"drive_{k:03d}.parquet",
            odometer_m,
            km_per_year / n_drives,
            law,
            tyre=tyre,
            duration_s=drive_s,
            sample_rate_hz=sample_rate_hz,
            ambient_c=float(np.clip(ambient[k], -20.0, 40.0)),
            sensor_offsets=eqx.tree_at(lambda s: s.radius_error, base, np.asarray(radius_error)),
            profile=profile,
        )
        drives.append(drive)
        loss[on_wheel] += drive.lost_mm
        losses.append([drive.lost_mm[:2].mean(), drive.lost_mm[2:].mean()])
        odometer_m += drive.interval_km * 1000.0
        depth_wheel = new_depth_mm - loss[on_wheel]
        due, next_reading = _readings_due(
            odometer_m / 1000.0, next_reading, reading_every_km, depth_wheel, reading_noise_mm, rng
        )
        readings.extend(due)
    return WearYearTruth(
        stream_paths=tuple(d.path for d in drives),
        gamma_mm3_per_j=gamma_mm3_per_j,
        kappa_per_k=kappa_per_k,
        change_drive_index=tuple(sorted(changes)),
        change_type=tuple(changes[k] for k in sorted(changes)),
        total_km=odometer_m / 1000.0,
        depth_mm=np.asarray(depth_rows),
        drive_work_j=np.asarray([d.work_j for d in drives]),
        drive_work_y_j=np.asarray([d.work_y_j for d in drives]),
        interval_loss_mm=np.asarray(losses),
        c_y_per_rad=drives[-1].c_y_per_rad if drives else float("nan"),
        readings=pd.DataFrame(readings, columns=["odometer_km", "axle", "depth_mm"]),
    )


class _WearLaw(NamedTuple):
    """The simulated wear law: γ [mm³/J], κ [1/K], the log-sd of how far a drive's wear
    stands for its interval's, and the tread's wear area [mm²]."""

    gamma_mm3_per_j: float
    kappa_per_k: float
    representativeness_sd: float
    wear_area_mm2: float


class _YearDrive(NamedTuple):
    """One drive of the year: its stream file, the tyre's true c_y [1/rad], the true work per
    axle (longitudinal, lateral) [J], the tread lost per wheel position over the interval it
    stands for [mm], and that interval [km]."""

    path: str
    c_y_per_rad: float
    work_j: list[float]
    work_y_j: np.ndarray
    lost_mm: np.ndarray
    interval_km: float


def _year_drive(
    rng: np.random.Generator,
    car: Vehicle,
    path: Path,
    odometer_m: float,
    mean_interval_km: float,
    law: _WearLaw,
    **drive,
) -> _YearDrive:
    """Simulate and write one drive (``drive``: :func:`simulate_drive`'s arguments) and wear
    the tyres by it over the interval it stands for: its own distance or more, about
    ``mean_interval_km``, its wear scaled by a log-normal representativeness factor."""
    truth, dt, drive_km = _write_drive(rng, car, path, odometer_m, **drive)
    interval_km = max(drive_km, mean_interval_km * rng.uniform(0.6, 1.4))
    work, work_y, volume = _wheel_wear(truth, car, dt, law.gamma_mm3_per_j, law.kappa_per_k)
    factor = interval_km / drive_km * rng.lognormal(0.0, law.representativeness_sd)
    lost = volume * factor / law.wear_area_mm2  # per wheel position (fl, fr, rl, rr)
    return _YearDrive(str(path), truth.c_y_per_rad, work, work_y, lost, interval_km)


def _change_schedule(
    n_drives: int, rotation_at: float | None, replacement_at: float | None
) -> dict[int, str]:
    """Drive index → ``"rotation"`` / ``"replacement"`` at those fractions of the year."""
    changes = {}
    if rotation_at is not None:
        changes[int(round(rotation_at * n_drives))] = "rotation"
    if replacement_at is not None:
        changes[int(round(replacement_at * n_drives))] = "replacement"
    return changes


def _ambient_c(rng: np.random.Generator, n_drives: int) -> np.ndarray:
    """Ambient temperature of each drive over the year [°C]: a seasonal cosine (10 ± 9 °C,
    warmest about mid-July) plus 3 °C day-to-day noise."""
    day = np.linspace(0.0, 365.0, n_drives, endpoint=False)
    return (
        10.0 + 9.0 * np.cos(2 * np.pi * (day - 200.0) / 365.0) + 3 * rng.standard_normal(n_drives)
    )


def _change_tyres(
    change_type: str,
    on_wheel: np.ndarray,
    eps: np.ndarray,
    loss: np.ndarray,
    rng: np.random.Generator,
    radius_spread: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(tyre on each wheel, per-tyre radius error, per-tyre loss [mm]) after a change.

    A rotation swaps the axles' tyres; a replacement mounts four new ones, each with its own
    manufacturing radius error and no wear.
    """
    if change_type == "rotation":
        return on_wheel[_ROTATED], eps, loss
    return np.arange(4), radius_spread * rng.standard_normal(4), np.zeros(4)


def _write_drive(
    rng: np.random.Generator, car: Vehicle, path: Path, odometer_m: float, *, tyre: str, **drive
) -> tuple[DriveTruth, np.ndarray, float]:
    """Simulate one drive (keyword arguments of :func:`simulate_drive`) and write its stream with
    an ``odometer`` column [m] continuing from ``odometer_m``.

    Returns its truth, the sample intervals [s] and the distance it drove [km].
    """
    df, truth = simulate_drive(int(rng.integers(2**31)), car, tyre, **drive)
    dt = np.diff(truth.time_s, append=truth.time_s[-1])
    travelled = np.cumsum(truth.vx_mps * dt)
    df["odometer"] = odometer_m + np.interp(df["time"], truth.time_s, travelled)
    write_stream(df, path)
    return truth, dt, float(travelled[-1] / 1000.0)


def _wheel_wear(
    truth: DriveTruth, car: Vehicle, dt: np.ndarray, gamma_mm3_per_j: float, kappa_per_k: float
) -> tuple[list[float], np.ndarray, np.ndarray]:
    """One drive's true friction work and worn volume (eq. 4.19a + b, 4.26).

    Returns the longitudinal work per axle (front, rear) [J], the lateral work per axle [J]
    and the worn volume per wheel position (fl, fr, rl, rr) [mm³] over the drive itself, each
    wheel's friction power (the lateral half each) times γ exp(κ (T − 20)).
    """
    power = np.abs(
        truth.rho_x * truth.wheel_load_n * truth.wheel_centre_speed_mps[:, :] * truth.slip
    )
    wheel_work = np.sum(power * dt[:, None], axis=0)
    work = [wheel_work[:2].sum(), wheel_work[2:].sum()]
    lateral = lateral_sliding_power(truth, car)  # (n, 2) per axle, half on each wheel
    work_y = np.sum(lateral * dt[:, None], axis=0)
    power = power + np.repeat(lateral / 2.0, 2, axis=1)
    rate = np.exp(kappa_per_k * (truth.tyre_temperature_c - 20.0))
    volume = gamma_mm3_per_j * np.sum(rate * power * dt[:, None], axis=0)  # per wheel
    return work, work_y, volume


def _readings_due(
    odometer_km: float,
    next_reading_km: float,
    reading_every_km: float,
    depth_wheel_mm: np.ndarray,
    noise_mm: float,
    rng: np.random.Generator,
) -> tuple[list[dict], float]:
    """The tread readings due by ``odometer_km`` (every ``reading_every_km``), and the next one.

    Each is the axle's mean depth over its two wheels plus Normal(0, ``noise_mm``) noise,
    rounded to 0.01 mm as a gauge reads.
    """
    readings = []
    while odometer_km >= next_reading_km:
        for axle, cols in (("front", [0, 1]), ("rear", [2, 3])):
            readings.append(
                {
                    "odometer_km": odometer_km,
                    "axle": axle,
                    "depth_mm": round(
                        float(depth_wheel_mm[cols].mean())
                        + noise_mm * float(rng.standard_normal()),
                        2,
                    ),
                }
            )
        next_reading_km += reading_every_km
    return readings, next_reading_km
