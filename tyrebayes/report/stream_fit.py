"""From stream files to a per-tyre posterior: features → windows → :func:`fit_tyre`.

The glue the demo and the report use: every drive of one tyre set goes through
:func:`tyrebayes.streams.validate_stream` and :func:`tyrebayes.streams.compute_features`; samples
with a usable V_x, no spin/lock flag and no cornering enter 0.25 s windows
(:func:`tyrebayes.inference.tyre_data.windowed_observations`), and the drives are stacked into one
:class:`~tyrebayes.inference.tyre_data.TyreObservations`.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from ..inference.tyre_data import TyreObservations, stack_drives, windowed_observations
from ..physics.vehicle import Vehicle
from ..streams import compute_features, validate_stream
from ..streams.segments import CORNERING

#: Tyre temperature assumed when a stream has no ``ambient_temperature`` column [°C].
DEFAULT_TEMPERATURE_C = 20.0


@dataclasses.dataclass(frozen=True)
class DriveWindows:
    """Windows of one drive and what the pipeline saw.

    Attributes
    ----------
    windows : dict
        Output of :func:`windowed_observations`.
    surface : str
    ambient_c : float
        Mean logged ambient temperature [°C] (or :data:`DEFAULT_TEMPERATURE_C`).
    duration_s : float
    usable_fraction : float
        Share of samples that entered the windows.
    """

    windows: dict
    surface: str
    ambient_c: float
    duration_s: float
    usable_fraction: float


def drive_windows(df: pd.DataFrame, vehicle: Vehicle, surface: str) -> DriveWindows:
    """Validate one stream table, compute its features and average them into windows."""
    stream = validate_stream(df, vehicle)
    feats = compute_features(stream, vehicle)
    usable = feats.valid & ~feats.spin & (feats.label != CORNERING)
    if "ambient_temperature" in df.columns and np.isfinite(df["ambient_temperature"]).any():
        ambient = float(np.nanmean(df["ambient_temperature"].to_numpy(float)))
    else:
        ambient = DEFAULT_TEMPERATURE_C
    windows = windowed_observations(
        feats.time_s,
        feats.slip_driven,
        feats.rho_driven,
        feats.slip_driven_sd,
        feats.rho_driven_sd,
        temperature_c=ambient,
        usable=usable,
    )
    return DriveWindows(
        windows=windows,
        surface=surface,
        ambient_c=ambient,
        duration_s=float(stream.duration_s),
        usable_fraction=float(np.mean(usable)),
    )


def stack(drives: list[DriveWindows]) -> TyreObservations:
    """Stack the windows of several drives of one tyre set."""
    return stack_drives([d.windows for d in drives], [d.surface for d in drives])
