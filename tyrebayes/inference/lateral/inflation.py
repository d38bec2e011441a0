"""How many correlated residual samples count as one: the variance inflation factor.

The residuals of both equations of the lateral model are correlated from sample to sample (the
signals are low-passed, and road bank and unmodelled dynamics vary slowly); the fit weights each
equation's likelihood by 1/VIF of its residuals at a first mode, without which the intervals
would count correlated samples as independent and be several times too narrow.
"""

from __future__ import annotations

import numpy as np

#: Batch lengths of the batch-means variance inflation [samples at 10 Hz]: 10 s, 30 s, 60 s.
INFLATION_BLOCKS = (100, 300, 600)
#: A batch length counts where the record holds at least this many batches.
MIN_BATCHES = 8


def residual_inflation(r: np.ndarray, mask: np.ndarray) -> float:
    """Variance inflation factor of residuals ``r`` on ``mask``: how many samples count as one.

    The largest of the AR(1) factor (1 + φ)/(1 − φ) and the batch-means factors (the variance of
    means of ``b`` consecutive samples against the variance of one sample, times ``b``, for each
    ``b`` of :data:`INFLATION_BLOCKS` with at least :data:`MIN_BATCHES` batches): the first sees
    the low-pass filter's correlation, the others the slow one of road bank and of a curve that
    misfits over a whole corner or a long bend, which AR(1) misses. At least 1.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> residual_inflation(rng.normal(size=20000), np.ones(20000, bool)) < 1.5
    True
    """
    x = r[mask] - np.mean(r[mask])
    var = float(np.mean(x**2))
    if var <= 0 or x.size < 20:
        return 1.0
    phi = float(np.mean(x[1:] * x[:-1]) / var)
    phi = min(max(phi, 0.0), 0.995)
    factors = [1.0, (1.0 + phi) / (1.0 - phi)]
    for block in INFLATION_BLOCKS:
        n_blocks = x.size // block
        if n_blocks >= MIN_BATCHES:
            means = x[: n_blocks * block].reshape(n_blocks, block).mean(axis=1)
            factors.append(block * float(np.var(means)) / var)
    return max(factors)
