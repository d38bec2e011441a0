"""Tyre temperature of the driven wheels, estimated from the stream with the lumped heat balance.

The stiffness of a tyre falls with its temperature (thesis ch. 3.3.1), and a tyre warms by tens
of kelvin within minutes of driving: rolling-resistance losses (~1 kW per tyre at 100 km/h)
dwarf the contact-patch friction work. A drive's windows therefore see a C_x that drifts with
speed history. Fitting one C_x at the ambient temperature reads that drift as noise the model
does not know: on 35 simulated one-hour drives (compact, 15 °C ambient, tyres warming from
ambient, fits with unit slip weights) the C_x error beyond the force gain had an sd of 3.0 %, and
2.1 % when the fit was given each window's true tyre temperature, while the posterior left room
for 0.9 %.

This module runs :func:`tyrebayes.physics.thermal.simulate_tyre_temperature` on the stream's own
speed, axle loads and friction power, with nominal thermal parameters. The estimate's *scale*
needs not be right: the model infers the temperature sensitivity κ of C_x, so a temperature rise
read 20 % too large gives a κ 20 % too small and the same C_x along the drive; what it needs is
the *shape* of the warm-up and cool-down, which is set by speed history.

Examples
--------
>>> import numpy as np
>>> t = np.arange(0.0, 1800.0, 0.1)
>>> temp = driven_tyre_temperature(t, np.full(t.size, 27.8), np.full(t.size, 5000.0),
...                                np.zeros(t.size), ambient_c=10.0)
>>> bool(temp[0] == 10.0), bool(temp[-1] > 25.0)
(True, True)
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from .._errors import BadInputError
from ..internal.device_arrays import device_array
from ..physics.thermal import ThermalParams, simulate_tyre_temperature
from .order_stats import median

# The thermal time constant is minutes (heat capacity / conductance ≈ 25 kJ/K / 54 W/K ≈ 8 min
# at 100 km/h), so 1 s block means lose nothing and keep the scan 100× shorter than at 100 Hz.
_BLOCK_S = 1.0

# The ambient and start temperatures go in as arrays: a Python float would be a static argument
# of filter_jit, and every drive's own ambient would compile (and keep) a scan of its own.
_scan = eqx.filter_jit(simulate_tyre_temperature)
# Blocks per compiled length of the scan (~17 min at 1 s blocks; 10-60 min drives: 4 lengths).
_PAD_BLOCKS = 1024


def driven_tyre_temperature(
    time_s: Float[np.ndarray, "n"],
    # User input checked at run time with a one-line error (not by jaxtyping, which raises a
    # TypeCheckError only where the tests switch it on).
    speed_mps: np.ndarray,
    fz_per_tyre_n: np.ndarray,
    friction_power_per_tyre_w: np.ndarray,
    *,
    ambient_c: float,
    initial_c: float | None = None,
    params: ThermalParams | None = None,
) -> Float[np.ndarray, "n"]:
    """Temperature of one driven tyre along a drive [°C] (lumped heat balance, thermal.py).

    Parameters
    ----------
    time_s : ndarray, shape (n,)
        Uniform, increasing sample times [s].
    speed_mps, fz_per_tyre_n, friction_power_per_tyre_w : ndarray, shape (n,)
        Speed [m/s], load of one driven tyre [N] and its friction power (thesis eq. 4.19a) [W].
        NaN (dropped samples) are bridged: the 1 s block means skip them, and a block with no
        valid sample holds the previous one's inputs.
    ambient_c : float
        Ambient temperature [°C].
    initial_c : float, optional
        Tyre temperature at the first sample [°C]; default ``ambient_c`` (a cold start).
    params : ThermalParams, optional
        Nominal thermal parameters (default :class:`ThermalParams`).

    Returns
    -------
    ndarray, shape (n,)
        Estimated tyre temperature at every sample [°C].

    Examples
    --------
    Ten minutes at 25 m/s from a cold start at 10 °C:

    >>> t = np.arange(0.0, 600.0, 0.1)
    >>> speed, load, power = np.full(t.size, 25.0), np.full(t.size, 4000.0), np.full(t.size, 200.0)
    >>> temperature = driven_tyre_temperature(t, speed, load, power, ambient_c=10.0)
    >>> float(temperature[0]), round(float(temperature[-1]), 1)
    (10.0, 25.3)
    """
    time_s = np.asarray(time_s, dtype=float)
    n = time_s.size
    channels = [np.asarray(x, dtype=float) for x in (speed_mps, fz_per_tyre_n)]
    friction = np.nan_to_num(np.asarray(friction_power_per_tyre_w, dtype=float), nan=0.0)
    for name, arr in zip(("speed", "load", "friction power"), (*channels, friction), strict=True):
        if arr.shape != (n,):
            raise BadInputError(f"tyre temperature: {name} expected shape ({n},), got {arr.shape}")
    if not np.isfinite(ambient_c):
        raise BadInputError(f"tyre temperature: expected a finite ambient, got {ambient_c}")
    if n < 2:
        return np.full(n, float(ambient_c if initial_c is None else initial_c))
    dt = median(np.diff(time_s), overwrite_input=True)  # np.median's, by one selection
    block = max(int(round(_BLOCK_S / dt)), 1)
    n_blocks = max(n // block, 1)
    means = [_block_means(x, block, n_blocks) for x in (*channels, friction)]
    speed, load, power = (_hold_last(np.abs(m) if i == 0 else m) for i, m in enumerate(means))
    start = float(ambient_c if initial_c is None else initial_c)
    # The scan is causal, so blocks appended at the end (the last inputs held, time running on)
    # leave the first n_blocks temperatures as they are: padded to a multiple of _PAD_BLOCKS, one
    # compiled scan serves every drive of similar length instead of one per drive.
    padded = -(-n_blocks // _PAD_BLOCKS) * _PAD_BLOCKS
    t_padded = time_s[0] + (np.arange(padded) + 0.5) * block * dt
    t_blocks = t_padded[:n_blocks]
    temps = np.asarray(
        _scan(
            ThermalParams() if params is None else params,
            device_array(t_padded),
            *(
                device_array(np.pad(x, (0, padded - n_blocks), mode="edge"))
                for x in (speed, load, power)
            ),
            jnp.asarray(float(ambient_c)),
            jnp.asarray(start),
        )
    )[:n_blocks]
    # Block means describe block centres; before the first centre the tyre is at its start.
    return np.interp(time_s, np.concatenate([[time_s[0]], t_blocks]), np.r_[start, temps])


def _block_means(values: np.ndarray, block: int, n_blocks: int) -> np.ndarray:
    cut = values[: n_blocks * block].reshape(n_blocks, -1)
    valid = np.isfinite(cut)
    counts = valid.sum(axis=1)
    total = np.where(valid, cut, 0.0).sum(axis=1)
    return np.where(counts > 0, total / np.maximum(counts, 1), np.nan)


def _hold_last(values: np.ndarray) -> np.ndarray:
    """NaN blocks take the previous valid block's value (the first valid one at the start)."""
    valid = np.isfinite(values)
    if not valid.any():
        return np.zeros_like(values)
    index = np.where(valid, np.arange(values.size), 0)
    np.maximum.accumulate(index, out=index)
    filled = values[index]
    first = np.flatnonzero(valid)[0]
    filled[:first] = values[first]
    return filled


def features_tyre_temperature(
    features, *, ambient_c: float, initial_c: float | None = None, params=None
) -> Float[np.ndarray, "n"]:
    """Driven-tyre temperature [°C] of a :class:`~tyrebayes.streams.StreamFeatures` stream.

    The driven axle's load and friction power are split evenly over its tyres (over all four for
    AWD); the speed is the vehicle's V_x. See :func:`driven_tyre_temperature`.

    Parameters
    ----------
    features : StreamFeatures
        From :func:`tyrebayes.streams.compute_features`.
    ambient_c : float
        Ambient temperature [°C].
    initial_c : float, optional
        Tyre temperature at the first sample [°C]; default ``ambient_c`` (a cold start).
    params : ThermalParams, optional
        Nominal thermal parameters (default :class:`~tyrebayes.physics.thermal.ThermalParams`).

    Returns
    -------
    ndarray, shape (n,)
        Estimated driven-tyre temperature at every sample of ``features`` [°C].

    Examples
    --------
    >>> from tyrebayes import compute_features, load_vehicle, read_stream, validate_stream
    >>> from tyrebayes._resources import data_dir
    >>> vehicle = load_vehicle("suv_rav4")
    >>> df = read_stream(data_dir() / "comma2k19_rav4_segment.csv")
    >>> features = compute_features(validate_stream(df, vehicle), vehicle)
    >>> temperature = features_tyre_temperature(features, ambient_c=15.0)
    >>> float(temperature[0]), round(float(temperature[-1]), 1)
    (15.0, 16.8)
    """
    axles = {"front": [0], "rear": [1], "both": [0, 1]}[features.driven_axle]
    tyres = 2 * len(axles)
    load = np.sum(features.fz_axle_n[:, axles], axis=1) / tyres
    return driven_tyre_temperature(
        features.time_s,
        features.vx_mps,
        load,
        features.friction_power_w / tyres,
        ambient_c=ambient_c,
        initial_c=initial_c,
        params=params,
    )


__all__ = ["driven_tyre_temperature", "features_tyre_temperature"]
