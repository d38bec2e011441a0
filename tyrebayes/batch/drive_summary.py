"""One drive's summary row: what the per-drive stage learnt about a log besides its windows.

:func:`drive_summary` is the one place the row is built. It carries the tread-wear evidence
(:data:`~tyrebayes.streams.wear_evidence.WEAR_EVIDENCE_COLUMNS`: friction work per axle, radius
ratios, distance), so that ``tyrebayes fit-wear`` reads a fleet run's ``drive_summaries.parquet``
without re-reading the logs.
"""

from __future__ import annotations

import math

import numpy as np

from ..inference.tyre.window_table import WindowTable
from ..physics.vehicle import Vehicle
from ..streams.segments import SEGMENT_REGIMES
from ..streams.wear_evidence import drive_wear_evidence
from .manifest import DriveItem


def drive_summary(
    item: DriveItem, stream, features, windows: WindowTable, vehicle: Vehicle
) -> dict:
    """The summary row of one processed drive (flat: str, float, int and bool values).

    Parameters
    ----------
    item : DriveItem
        The manifest row.
    stream : ValidatedStream
        The validated log (:func:`tyrebayes.streams.validate_stream`).
    features : StreamFeatures
        Its features (:func:`tyrebayes.streams.compute_features`).
    windows : WindowTable
        Its windowed observations (:func:`tyrebayes.inference.observations_from_features`).
    vehicle : Vehicle
        The car (for the wear evidence's axle loads and radii).

    Returns
    -------
    dict
        ``drive_id``, ``tyre_set_id``, ``vehicle``, ``surface``, ``tyre_type``, ``ambient_c``
        [°C], ``duration_s`` [s], ``samples``, ``sample_rate_hz``, ``valid_fraction``,
        ``seconds_<regime>`` and ``segments_<regime>`` per :data:`SEGMENT_REGIMES`, smoothed noise
        (``noise_vx_mps``, ``noise_slip_velocity_mps``, ``noise_ax_mps2``), nuisances
        (``ax_offset_mps2``, ``ax_gain``, ``speed_scale``), ``friction_work_driven_j`` (the
        driven axle's ∫|F_x V_x σ_x| dt, thesis eq. 4.19a/4.26), ``windows``, ``abs_windows``,
        ``flags`` (the stream's flags, " | "-joined), and the columns of
        :data:`~tyrebayes.streams.wear_evidence.WEAR_EVIDENCE_COLUMNS` not named above.
    """
    time_s = features.time_s
    dt = 1.0 / features.sample_rate_hz
    segments = features.segments()
    nuis = features.nuisances
    noise = nuis.smoothed_noise
    power = features.friction_power_w
    row = {
        "drive_id": item.drive_id,
        "path": item.path,
        "tyre_set_id": item.tyre_set_id,
        "vehicle": item.vehicle,
        "surface": item.surface,
        "tyre_type": item.tyre_type,
        "ambient_c": float(item.ambient_c),
        "duration_s": float(time_s[-1] - time_s[0]) if time_s.size else 0.0,
        "samples": int(time_s.size),
        "sample_rate_hz": float(features.sample_rate_hz),
        "valid_fraction": float(np.mean(features.valid)) if time_s.size else 0.0,
        **{f"seconds_{k}": float(segments[k]["seconds"]) for k in SEGMENT_REGIMES},
        **{f"segments_{k}": int(segments[k]["count"]) for k in SEGMENT_REGIMES},
        "noise_vx_mps": float(noise["vx_mps"]),
        "noise_slip_velocity_mps": float(noise["slip_velocity_driven_mps"]),
        "noise_ax_mps2": float(noise["ax_mps2"]),
        "ax_offset_mps2": float(nuis.ax_offset_mps2),
        "ax_gain": float(nuis.ax_gain.applied),
        "speed_scale": float(nuis.speed_scale),
        "friction_work_driven_j": float(np.nansum(power) * dt),
        "windows": len(windows),
        "abs_windows": int(np.sum(windows.at_limit)),
        "flags": " | ".join(stream.flags),
    }
    wear = drive_wear_evidence(stream, vehicle, features=features).row()
    row.update({k: v for k, v in wear.items() if k not in row})
    return {
        k: (v if not isinstance(v, float) or math.isfinite(v) else float("nan"))
        for k, v in row.items()
    }
