"""A stream file to the online estimator's steps: the stream pipeline of ``fit-tyre``, unstacked."""

from __future__ import annotations

import numpy as np

from ..._errors import BadInputError
from ..tyre.data import SURFACES, observations_from_features
from .windows import STEP_S, WindowBlocks, window_blocks


def stream_windows(
    path,
    vehicle,
    *,
    surface: str = "dry",
    temperature_c: float | None = None,
    ambient_c: float | None = None,
    channel_map: dict[str, str] | None = None,
) -> dict[str, np.ndarray]:
    """Read, validate and window one stream as :func:`~..tyre_data.observations_from_stream` does.

    Returns the windows (:func:`~..tyre_data.observations_from_features`), in time order of
    their steps once grouped by :func:`stream_steps`.
    """
    from ..._domain import load_vehicle
    from ...physics.vehicle import Vehicle
    from ...streams import compute_features, read_stream, validate_stream
    from ...streams.tyre_temperature import features_tyre_temperature

    if not isinstance(vehicle, Vehicle):
        try:
            vehicle = load_vehicle(vehicle)
        except ValueError as err:
            raise BadInputError(str(err).splitlines()[0]) from None
    if surface not in SURFACES:
        raise BadInputError(f"surface: expected one of {SURFACES}, got {surface!r}")
    stream = validate_stream(read_stream(path, channel_map), vehicle)
    if ambient_c is None:
        ambient_c = 20.0
        if "ambient_temperature" in stream.data:
            ambient = stream.data["ambient_temperature"].to_numpy(dtype=float)
            if np.isfinite(ambient).any():
                ambient_c = float(np.nanmean(ambient))
    features = compute_features(stream, vehicle)
    if temperature_c is None:
        temperature_c = features_tyre_temperature(features, ambient_c=ambient_c)
    windows = observations_from_features(features, temperature_c=temperature_c)
    if len(windows["slip"]) < 10:
        raise BadInputError(
            f"online estimator: expected at least 10 usable windows, got {len(windows['slip'])}"
        )
    return windows


def stream_steps(windows: dict[str, np.ndarray], surface: str = "dry") -> WindowBlocks:
    """The windows in steps of :data:`STEP_S`, padded to the width of a full step.

    A full step of 0.25 s windows holds STEP_S / 0.25 of them; every stream then shares one
    compiled filter (per number of steps).
    """
    times = np.asarray(windows["time_s"], dtype=float)
    spacing = float(np.median(np.diff(np.sort(times)))) if times.size > 1 else 0.25
    width = int(np.ceil(STEP_S / max(spacing, 1e-3))) + 1
    return window_blocks(windows, surface, width=width)


__all__ = ["stream_steps", "stream_windows"]
