"""Per-channel noise and quantisation estimates from the data themselves.

Real sensors are not ideal: CAN wheel speeds come in steps (0.01 km/h on many cars), IMUs add white
noise and vibration. Both are estimated here so that the inference can use them as measurement
error instead of assuming them away.

Examples
--------
>>> import numpy as np
>>> x = np.round(np.linspace(10, 12, 1000) / 0.01) * 0.01
>>> round(quantisation_step(x), 4)
0.01
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Float

# Above this many values the quantisation estimate uses an evenly strided subset: the step is a
# property of the encoding, 100 000 samples pin it down and keep np.unique cheap on 10 h logs.
_MAX_VALUES = 100_000


def quantisation_step(x: Float[np.ndarray, "n"]) -> float:
    """Resolution of a quantised signal, or 0.0 when the values look continuous.

    The gaps between neighbouring distinct values of a signal encoded with step q are integer
    multiples of q. The smallest gap is taken as q and accepted only if 95 % of all gaps are
    within 10 % of a multiple of it.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Raw samples as logged (before any resampling, which blurs the steps); NaN ignored.

    Returns
    -------
    float
        Step in the unit of ``x``; 0.0 if no step is found.
    """
    values = x[np.isfinite(x)]
    if values.size > _MAX_VALUES:
        values = values[:: values.size // _MAX_VALUES + 1]
    distinct = np.unique(values)
    if distinct.size < 4:
        return 0.0
    gaps = np.diff(distinct)
    # A relative floor against float noise in values written as decimal text.
    scale = max(float(np.max(np.abs(distinct))), 1e-12)
    gaps = gaps[gaps > 1e-9 * scale]
    if gaps.size < 3:
        return 0.0
    step = float(np.min(gaps))
    ratio = gaps / step
    off = np.abs(ratio - np.round(ratio))
    if np.quantile(off, 0.95) > 0.1:
        return 0.0
    unit_gaps = gaps[np.round(ratio) == 1]
    return float(np.median(unit_gaps))


def white_noise_sd(x: Float[np.ndarray, "n"], quantisation: float = 0.0) -> float:
    """Standard deviation of the sample-to-sample noise of a signal on a uniform time base.

    From the second difference: for white noise of sd s, ``Δ²x`` has sd ``s√6``, while smooth
    vehicle motion contributes almost nothing at 50-100 Hz. The median absolute deviation keeps
    spikes from dominating. Quantisation of step q adds ``q/√12`` (a step signal can give a zero
    MAD, which would claim a perfect sensor).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Signal; NaN samples are skipped (differences spanning them are dropped).
    quantisation : float
        Known quantisation step in the unit of ``x`` (0 for none).

    Returns
    -------
    float
        Noise sd in the unit of ``x``; NaN if fewer than 10 valid second differences.
    """
    d2 = x[2:] - 2.0 * x[1:-1] + x[:-2]
    d2 = d2[np.isfinite(d2)]
    if d2.size < 10:
        return float("nan")
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    sd = 1.4826 * mad / np.sqrt(6.0)
    return float(np.sqrt(sd**2 + quantisation**2 / 12.0))
