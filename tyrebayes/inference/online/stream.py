"""A stream file to the online estimator's steps: the stream pipeline of ``fit-tyre``, unstacked."""

from __future__ import annotations

import numpy as np

from ..._errors import BadInputError
from ..tyre.data import WindowTable, windows_from_stream
from .windows import STEP_S, WindowBlocks, window_blocks


def stream_windows(
    path,
    vehicle,
    *,
    surface: str = "dry",
    temperature_c: float | None = None,
    ambient_c: float | None = None,
    channel_map: dict[str, str] | None = None,
) -> WindowTable:
    """Read, validate and window one stream (:func:`~..tyre.data.windows_from_stream`).

    Parameters
    ----------
    path : path-like or ValidatedStream
        Stream file (CSV, Parquet or MDF4), or a stream already read and validated.
    vehicle : Vehicle or str
        Vehicle parameters, a preset name or a TOML path.
    surface : str
        Road surface of the drive, one of :data:`tyrebayes.SURFACES`.
    temperature_c : float, optional
        A fixed tyre temperature [°C]; default the driven tyres' temperature estimated sample by
        sample.
    ambient_c : float, optional
        Ambient temperature [°C] for that estimate; default the stream's, else 20 °C.
    channel_map : dict of str to str, optional
        Source column name to contract name (:func:`tyrebayes.read_stream`); unused for a
        validated stream.

    Returns
    -------
    WindowTable
        The windows, in time order of their steps once grouped by :func:`stream_steps`.

    Raises
    ------
    BadInputError
        As :func:`~..tyre.data.windows_from_stream`, or fewer than 10 windows.

    Examples
    --------
    The shipped one-minute RAV4 segment:

    >>> from tyrebayes import load_vehicle
    >>> from tyrebayes._resources import data_dir
    >>> path = data_dir() / "comma2k19_rav4_segment.csv"
    >>> windows = stream_windows(path, load_vehicle("suv_rav4"))
    >>> windows.slip.shape, bool(np.all(np.diff(windows.time_s) > 0))
    ((123,), True)
    """
    windows = windows_from_stream(
        path,
        vehicle,
        surface=surface,
        temperature_c=temperature_c,
        ambient_c=ambient_c,
        channel_map=channel_map,
    )
    if len(windows) < 10:
        raise BadInputError(
            f"online estimator: expected at least 10 usable windows, got {len(windows)}"
        )
    return windows


def stream_steps(
    windows: WindowTable, surface: str = "dry", *, max_step_s: float | None = None
) -> WindowBlocks:
    """The windows in steps (:func:`~.windows.window_blocks`), padded to STEP_S of windows.

    STEP_S of 0.25 s windows holds STEP_S / 0.25 + 1 of them at most; every stream then shares
    one compiled filter (per number of steps).

    Parameters
    ----------
    windows : WindowTable
        Slip windows (:func:`stream_windows`).
    surface : str
        One of :data:`tyrebayes.SURFACES`.
    max_step_s : float, optional
        Packs sparse driving into fewer steps (:func:`~.windows.window_blocks`).

    Returns
    -------
    WindowBlocks

    Examples
    --------
    The shipped one-minute segment fills two steps of 30 s:

    >>> from tyrebayes import load_vehicle
    >>> from tyrebayes._resources import data_dir
    >>> path = data_dir() / "comma2k19_rav4_segment.csv"
    >>> windows = stream_windows(path, load_vehicle("suv_rav4"))
    >>> blocks = stream_steps(windows)
    >>> blocks.slip.shape[0], int(blocks.mask.sum())
    (2, 123)
    """
    times = windows.time_s
    spacing = float(np.median(np.diff(np.sort(times)))) if times.size > 1 else 0.25
    width = int(np.ceil(STEP_S / max(spacing, 1e-3))) + 1
    return window_blocks(windows, surface, width=width, max_step_s=max_step_s)


__all__ = ["stream_steps", "stream_windows"]
