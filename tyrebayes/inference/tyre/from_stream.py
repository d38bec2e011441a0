"""A stream file to the per-tyre model's windows: read, validate, features, windows.

The stream pipeline of ``fit-tyre`` and of the online estimator. Re-exported by
:mod:`tyrebayes.inference.tyre.data`.
"""

from __future__ import annotations

from ..._domain import SURFACES
from ..._errors import BadInputError
from .observations import TyreObservations, stack_drives
from .window_table import WindowTable
from .windows import observations_from_features


def windows_from_stream(
    path,
    vehicle,
    *,
    surface: str = "dry",
    temperature_c: float | None = None,
    ambient_c: float | None = None,
    window_s: float = 0.25,
    channel_map: dict[str, str] | None = None,
) -> WindowTable:
    """Read, validate and window one stream file: the windows of one drive, in time order.

    The stream pipeline of ``fit-tyre`` (:func:`observations_from_stream` stacks its result) and
    of the online estimator.

    Parameters
    ----------
    path : path-like or ValidatedStream
        Stream file (CSV, Parquet or MDF4) in the DESIGN.md contract, or a stream already read
        and validated against ``vehicle`` (``channel_map`` then unused).
    vehicle : Vehicle or str
        Vehicle parameters, a preset name (``suv_rav4``) or a TOML path.
    surface : str
        Road surface of the drive, one of :data:`SURFACES` (sets the μ_max prior).
    temperature_c : float, optional
        A fixed tyre temperature for the whole drive [°C]. Default: the driven tyres' temperature
        estimated sample by sample from the drive's speed and loads
        (:func:`~tyrebayes.streams.tyre_temperature.features_tyre_temperature`), starting cold.
    ambient_c : float, optional
        Ambient temperature [°C] for that estimate; default the mean ``ambient_temperature``
        column, else 20 °C.
    window_s : float
        Window length [s].

    Returns
    -------
    WindowTable
        The drive's windows (:func:`~.windows.observations_from_features`).

    Raises
    ------
    BadInputError
        Missing file, missing columns, unknown vehicle or too few usable windows.
    """
    from ..._domain import load_vehicle
    from ...physics.vehicle import Vehicle
    from ...streams import ValidatedStream, compute_features, read_stream, validate_stream
    from ...streams.tyre_temperature import features_tyre_temperature

    if not isinstance(vehicle, Vehicle):
        try:
            vehicle = load_vehicle(vehicle)
        except ValueError as err:
            raise BadInputError(str(err).splitlines()[0]) from None
    if surface not in SURFACES:
        raise BadInputError(f"surface: expected one of {SURFACES}, got {surface!r}")
    if isinstance(path, ValidatedStream):
        # Already read and validated by the caller (fit-tyre reads the flags and the frame too).
        stream = path
    else:
        stream = validate_stream(read_stream(path, channel_map), vehicle)
    if ambient_c is None:
        ambient_c = stream.mean_ambient_c()
    features = compute_features(stream, vehicle)
    if temperature_c is None:
        temperature_c = features_tyre_temperature(features, ambient_c=ambient_c)
    return observations_from_features(features, temperature_c=temperature_c, window_s=window_s)


def observations_from_stream(
    path,
    vehicle,
    *,
    surface: str = "dry",
    temperature_c: float | None = None,
    ambient_c: float | None = None,
    window_s: float = 0.25,
    channel_map: dict[str, str] | None = None,
) -> TyreObservations:
    """Read, validate and window one stream file for :func:`tyrebayes.inference.fit_tyre`.

    :func:`windows_from_stream` (same parameters and errors), stacked as one drive.

    Examples
    --------
    >>> from tyrebayes import load_vehicle
    >>> from tyrebayes._resources import data_dir
    >>> path = data_dir() / "comma2k19_rav4_segment.csv"
    >>> obs = observations_from_stream(path, load_vehicle("suv_rav4"))
    >>> obs.n_drives, obs.surfaces, int(obs.mask.sum()) > 100
    (1, ('dry',), True)
    """
    windows = windows_from_stream(
        path,
        vehicle,
        surface=surface,
        temperature_c=temperature_c,
        ambient_c=ambient_c,
        window_s=window_s,
        channel_map=channel_map,
    )
    return stack_drives([windows], [surface])
