"""A year of one car's drives whose tyres wear with a known γ and κ, written as stream files.

Each logged drive (:func:`~tyrebayes.simulate.drive.simulate_drive`, short and at a low rate to
stay cheap) stands for the distance to the next one, which the stream's extra ``odometer``
column [m] records. Truth per drive and wheel: the tyre's friction work
Σ |ρ_x F_z V σ_x| dt from the simulator's own slip and force (longitudinal only), the worn volume
γ Σ exp(κ (T − 20)) w dt with the simulated tyre temperature T (eq. 4.26 with the package's
temperature extension), scaled to the interval's distance and by a log-normal factor
(``representativeness_sd``: the unlogged driving differs from the logged drive). The worn depth
shrinks each tyre's rolling radius one to one, and the next drive's wheel speeds carry it
(``SensorTruth.radius_error``); each tyre also has its own manufacturing radius error
(``radius_spread``), which moves with it. A rotation swaps front and rear tyres on each side; a
replacement mounts four new tyres. Tread-depth readings (per axle, the mean of its two tyres plus
gauge noise) are taken at service intervals.

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

import equinox as eqx
import numpy as np
import pandas as pd

from .._domain import load_vehicle
from ..physics.wear import TreadGeometry
from ..streams.io import write_stream
from .drive import seed_sequence, simulate_drive
from .sensors import SensorModel, draw_sensor_truth

#: Wheel order (fl, fr, rl, rr) of the tyres after a rotation (front and rear swap per side).
_ROTATED = np.array([2, 3, 0, 1])


class WearYearTruth(eqx.Module):
    """What :func:`simulate_wear_year` made: files, the true parameters and tyre changes.

    ``change_drive_index`` / ``change_kind``: the drive at which each change took effect and
    ``"rotation"`` or ``"replacement"``. ``depth_mm[k, i]``: true depth of the tyre on wheel i
    (fl, fr, rl, rr) at the start of drive k. ``drive_work_j[k, a]``: true longitudinal friction
    work of axle a (front, rear) in logged drive k [J]. ``readings``: odometer_km, axle, depth_mm.
    """

    stream_paths: tuple[str, ...] = eqx.field(static=True)
    gamma_mm3_per_j: float
    kappa_per_k: float
    change_drive_index: tuple[int, ...] = eqx.field(static=True)
    change_kind: tuple[str, ...] = eqx.field(static=True)
    total_km: float
    depth_mm: np.ndarray
    drive_work_j: np.ndarray
    readings: pd.DataFrame = eqx.field(static=True)


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
) -> WearYearTruth:
    """Simulate and write one year of drives (module docstring); returns the truth.

    ``rotation_at`` / ``replacement_at`` are fractions of the year's drives (None: none).
    Streams are written as ``drive_000.parquet``, ... into ``out_dir``.
    """
    geom = TreadGeometry() if geom is None else geom
    car = load_vehicle(vehicle)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed_sequence(seed).spawn(1)[0])
    sensor = SensorModel()
    base = draw_sensor_truth(rng, sensor, car.wheel_radius_m)
    eps = radius_spread * rng.standard_normal(4)  # per tyre, moves with the tyre
    loss = np.zeros(4)  # per tyre [mm]
    on_wheel = np.arange(4)  # tyre index on (fl, fr, rl, rr)
    mean_interval = km_per_year / n_drives
    changes = {}
    if rotation_at is not None:
        changes[int(round(rotation_at * n_drives))] = "rotation"
    if replacement_at is not None:
        changes[int(round(replacement_at * n_drives))] = "replacement"
    day = np.linspace(0.0, 365.0, n_drives, endpoint=False)
    ambient = (
        10.0 + 9.0 * np.cos(2 * np.pi * (day - 200.0) / 365.0) + 3 * rng.standard_normal(n_drives)
    )
    odometer_m = 0.0
    paths, depth_rows, readings, works = [], [], [], []
    next_reading = reading_every_km
    for k in range(n_drives):
        if k in changes:
            if changes[k] == "rotation":
                on_wheel = on_wheel[_ROTATED]
            else:
                on_wheel = np.arange(4)
                eps = radius_spread * rng.standard_normal(4)
                loss = np.zeros(4)
        depth_rows.append(new_depth_mm - loss[on_wheel])
        radius_error = eps[on_wheel] - loss[on_wheel] / (1000.0 * car.wheel_radius_m)
        offsets = eqx.tree_at(lambda s: s.radius_error, base, np.asarray(radius_error))
        df, truth = simulate_drive(
            int(rng.integers(2**31)),
            car,
            tyre,
            duration_s=drive_s,
            sample_rate_hz=sample_rate_hz,
            ambient_c=float(np.clip(ambient[k], -20.0, 40.0)),
            sensor_offsets=offsets,
        )
        dt = np.diff(truth.time_s, append=truth.time_s[-1])
        travelled = np.cumsum(truth.vx_mps * dt)
        df["odometer"] = odometer_m + np.interp(df["time"], truth.time_s, travelled)
        path = out / f"drive_{k:03d}.parquet"
        write_stream(df, path)
        paths.append(str(path))
        drive_km = float(travelled[-1] / 1000.0)
        interval_km = max(drive_km, mean_interval * rng.uniform(0.6, 1.4))
        power = np.abs(
            truth.rho_x * truth.wheel_load_n * truth.wheel_centre_speed_mps[:, :] * truth.slip
        )
        wheel_work = np.sum(power * dt[:, None], axis=0)
        works.append([wheel_work[:2].sum(), wheel_work[2:].sum()])
        rate = np.exp(kappa_per_k * (truth.tyre_temperature_c - 20.0))
        volume = gamma_mm3_per_j * np.sum(rate * power * dt[:, None], axis=0)  # per wheel
        factor = interval_km / drive_km * rng.lognormal(0.0, representativeness_sd)
        loss[on_wheel] += volume * factor / geom.wear_area_mm2
        odometer_m += interval_km * 1000.0
        while odometer_m / 1000.0 >= next_reading:
            depth_axle = new_depth_mm - loss[on_wheel]
            for axle, cols in (("front", [0, 1]), ("rear", [2, 3])):
                readings.append(
                    {
                        "odometer_km": odometer_m / 1000.0,
                        "axle": axle,
                        "depth_mm": round(
                            float(depth_axle[cols].mean())
                            + reading_noise_mm * float(rng.standard_normal()),
                            2,
                        ),
                    }
                )
            next_reading += reading_every_km
    kinds = tuple(changes[k] for k in sorted(changes))
    return WearYearTruth(
        stream_paths=tuple(paths),
        gamma_mm3_per_j=gamma_mm3_per_j,
        kappa_per_k=kappa_per_k,
        change_drive_index=tuple(sorted(changes)),
        change_kind=kinds,
        total_km=odometer_m / 1000.0,
        depth_mm=np.asarray(depth_rows),
        drive_work_j=np.asarray(works),
        readings=pd.DataFrame(readings, columns=["odometer_km", "axle", "depth_mm"]),
    )
