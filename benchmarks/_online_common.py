"""Shared by the online benchmarks: simulated drives (stream pipeline) and the external drives."""

from __future__ import annotations

import os

import numpy as np
from _data import external_drives

from tyrebayes import (
    WindowTable,
    compute_features,
    features_tyre_temperature,
    load_vehicle,
    observations_from_features,
    validate_stream,
)
from tyrebayes.simulate import (
    ProfileOptions,
    ThermalSpread,
    TyreSpec,
    VehicleSpread,
    draw_database_curve,
    draw_true_thermal,
    draw_true_vehicle,
    simulate_drive,
)

TYRES = ("winter", "all_season", "summer")


def machine() -> dict:
    """What the timings ran on; the load average says how much else was running."""
    return {
        "note": "timings include whatever else ran on the machine: see load_average_1min",
        "cpu_count": os.cpu_count(),
        "load_average_1min": os.getloadavg()[0],
    }


def simulated_windows(
    seed: int,
    duration_s: float,
    *,
    tyre: TyreSpec | None = None,
    abs_events: int = 1,
    vehicle_name: str = "compact_fwd",
):
    """One simulated drive (car and thermal spread as in tyre_recovery.py) as windows.

    Returns ``(windows, truth, tyre)``; ``tyre`` is the TyreSpec driven (drawn if not given:
    a typical tyre of a cycled type with a Magic Formula shape from the shipped database).
    """
    vehicle = load_vehicle(vehicle_name)
    if tyre is None:
        kind = TYRES[seed % len(TYRES)]
        tyre = TyreSpec.from_type(
            kind, magic_formula=draw_database_curve(np.random.default_rng([seed, 9]))
        )
    car = draw_true_vehicle(np.random.default_rng([seed, 7]), vehicle, VehicleSpread())
    thermal = draw_true_thermal(np.random.default_rng([seed, 8]), ThermalSpread())
    df, truth = simulate_drive(
        seed,
        car,
        tyre,
        duration_s=duration_s,
        profile=ProfileOptions(n_abs_events=abs_events),
        ambient_c=15.0,
        thermal=thermal,
    )
    features = compute_features(validate_stream(df, vehicle), vehicle)
    temperature = features_tyre_temperature(features, ambient_c=15.0)
    return observations_from_features(features, temperature_c=temperature), truth, tyre


def true_c_x_so_far(truth, times_s: np.ndarray) -> np.ndarray:
    """Mean true C_x (driven wheels, at their temperature) over the drive up to each time."""
    t = np.asarray(truth.time_s, dtype=float)
    c = np.asarray(truth.c_x, dtype=float)
    cumulative = np.cumsum(c) / np.arange(1, len(c) + 1)
    idx = np.clip(np.searchsorted(t, times_s, side="right") - 1, 0, len(c) - 1)
    return cumulative[idx]


def external_entries() -> list[dict]:
    """The external drives' truth entries (``_data.external_drives``), in name order."""
    return [drive.truth for drive in external_drives()]


def external_windows(entry: dict) -> WindowTable:
    """An external drive through the stream pipeline as a new user's fit-tyre would read it."""
    (drive,) = external_drives(names=entry["name"])
    vehicle = drive.vehicle()
    stream = drive.validated(vehicle)
    features = compute_features(stream, vehicle)
    temperature = features_tyre_temperature(features, ambient_c=20.0)
    return observations_from_features(features, temperature_c=temperature)
