"""Several drives of one tyre set on different days: shared C_xr, different surfaces and weather.

Examples
--------
>>> drives = simulate_tyre_set_drives(0, "compact_fwd", "winter", n_drives=2, duration_s=10.0,
...                                   surfaces=("snow", "dry"), ambient_c=(-5.0, 8.0))
>>> [t.surface for _, t in drives], drives[0][1].c_xr == drives[1][1].c_xr
(['snow', 'dry'], True)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from .._domain import load_vehicle
from ..physics.vehicle import Vehicle
from .drive import seed_sequence, simulate_drive
from .profiles import ProfileOptions
from .sensors import SensorModel, SensorTruth, draw_sensor_truth
from .truth import DriveTruth
from .tyre_spec import TyreSpec

#: Day-to-day change of the per-wheel radius errors (pressure, wear) as a fraction [-].
DAILY_RADIUS_DRIFT_SD = 0.0005


def _per_drive(value, n: int, name: str) -> list:
    if isinstance(value, str) or np.ndim(value) == 0:
        return [value] * n
    seq = list(value)
    if len(seq) != n:
        raise ValueError(f"{name}: expected a single value or {n} values, got {len(seq)}")
    return seq


def simulate_tyre_set_drives(
    key_or_seed,
    vehicle: Vehicle | str,
    tyre: TyreSpec | str,
    *,
    n_drives: int,
    duration_s: float | int | Sequence[float],
    surfaces: str | Sequence[str] = ("dry", "wet", "snow"),
    ambient_c: float | int | Sequence[float] | None = None,
    sample_rate_hz: float | int = 100.0,
    tyre_model: str = "magic_formula",
    profile: ProfileOptions | Sequence[ProfileOptions] | None = None,
    sensor: SensorModel | None = None,
) -> list[tuple[pd.DataFrame, DriveTruth]]:
    """Drives of one tyre set (one C_xr, one car) on different days.

    Parameters
    ----------
    key_or_seed : int or jax PRNG key
        Seed of the whole set.
    vehicle, tyre :
        As in :func:`~tyrebayes.simulate.drive.simulate_drive`; the same tyre (C_xr, μ per surface)
        in every drive.
    n_drives : int
        Number of drives (days).
    duration_s : float or sequence
        Duration of each drive [s].
    surfaces : str or sequence of str
        Surfaces, cycled over the drives when fewer than ``n_drives`` are given.
    ambient_c : float, sequence or None
        Ambient temperature per drive [°C]; default: drawn per surface (snow/ice −12…0 °C, wet
        2…15 °C, dry 5…30 °C).
    sample_rate_hz, tyre_model, profile, sensor :
        As in :func:`simulate_drive` (``profile`` may be one per drive).

    Returns
    -------
    list of (stream, truth)
        One per drive. The per-wheel radius errors and IMU mounting are the car's and shared, with
        a small day-to-day drift (:data:`DAILY_RADIUS_DRIFT_SD`) of the radii.
    """
    if not (isinstance(n_drives, int | np.integer) and n_drives >= 1):
        raise ValueError(f"n_drives: expected an integer >= 1, got {n_drives!r}")
    if isinstance(vehicle, str):
        name = vehicle
        vehicle_obj = load_vehicle(vehicle)
    else:
        name, vehicle_obj = "", vehicle
    if isinstance(tyre, str):
        tyre = TyreSpec.from_type(tyre)
    surf_list = [surfaces] * n_drives if isinstance(surfaces, str) else list(surfaces)
    if not surf_list:
        raise ValueError("surfaces: expected at least one surface, got none")
    surf_list = [surf_list[i % len(surf_list)] for i in range(n_drives)]
    durations = _per_drive(duration_s, n_drives, "duration_s")
    profiles = (
        _per_drive(profile, n_drives, "profile")
        if not isinstance(profile, ProfileOptions)
        else [profile] * n_drives
    )
    sensor = sensor or SensorModel()
    children = seed_sequence(key_or_seed).spawn(n_drives + 1)
    rng = np.random.default_rng(children[0])
    if ambient_c is None:
        ranges = {"snow": (-12.0, 0.0), "ice": (-12.0, 0.0), "wet": (2.0, 15.0), "dry": (5.0, 30.0)}
        temps = [float(rng.uniform(*ranges[s])) for s in surf_list]
    else:
        temps = [float(t) for t in _per_drive(ambient_c, n_drives, "ambient_c")]
    car = draw_sensor_truth(rng, sensor, vehicle_obj.wheel_radius_m)
    out = []
    for i in range(n_drives):
        drift = rng.standard_normal(4) * DAILY_RADIUS_DRIFT_SD
        offsets = SensorTruth(
            radius_error=np.asarray(car.radius_error) + drift,
            imu_bias_mps2=np.asarray(car.imu_bias_mps2),
            mounting_pitch_rad=car.mounting_pitch_rad,
            yaw_rate_bias_radps=car.yaw_rate_bias_radps,
            wheel_speed_step_radps=car.wheel_speed_step_radps,
            ax_gain=car.ax_gain,
        )
        seed = int(children[i + 1].generate_state(1)[0])
        out.append(
            simulate_drive(
                seed,
                name or vehicle_obj,
                tyre,
                duration_s=float(durations[i]),
                sample_rate_hz=sample_rate_hz,
                surface=surf_list[i],
                ambient_c=temps[i],
                profile=profiles[i],
                tyre_model=tyre_model,
                sensor=sensor,
                sensor_offsets=offsets,
            )
        )
    return out
