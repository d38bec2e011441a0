"""Medians and quantiles of long 1-D arrays by single-rank selection, equal to NumPy's.

``np.median`` of an even-length array and ``np.quantile`` ask ``np.partition`` for two or three
ranks at once, which falls back to a generic introselect: about 3.5 ms on 360 000 samples (one
hour at 100 Hz), where a partition for one rank takes a SIMD selection of about 0.5 ms. The
stream stage takes some fifty medians and quantiles of hour-long arrays, so here each is one
single-rank partition plus a ``min``/``max`` for the neighbouring rank; where one value holds
the rank (ties: a quantised signal's differences), two counts; where the values are few, a
sort. The order statistics are exact and combined with NumPy's own arithmetic (the mean of the
two middle values; its linear interpolation of the ``"linear"`` method), so the results are
NumPy's to the last bit (``tests/streams/test_order_stats.py``).

Examples
--------
>>> import numpy as np
>>> x = np.random.default_rng(0).normal(size=10_000)
>>> bool(median(x) == np.median(x)), bool(quantile(x, 0.25) == np.quantile(x, 0.25))
(True, True)
"""

from __future__ import annotations

import math

import numpy as np
from jaxtyping import Float

# Below this size NumPy's own call is as fast (its overhead dominates): use it.
_SMALL = 2048


def median(x: Float[np.ndarray, "n"], overwrite_input: bool = False) -> float:
    """``float(np.median(x))`` of a 1-D array (NaN if it holds a NaN or is empty).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Values.
    overwrite_input : bool
        Let the selection reorder ``x`` in place instead of a copy (for a caller's temporary).

    Returns
    -------
    float
    """
    x = np.asarray(x, dtype=float)
    if x.size < _SMALL or np.isnan(x).any():
        return float(np.median(x))
    return _middle(x, x.size, overwrite_input)


def median_at_most(x: Float[np.ndarray, "n"], limit: float, overwrite_input: bool = False) -> float:
    """``float(np.median(x[x <= limit]))`` of a 1-D array, without forming ``x[x <= limit]``.

    The values at most ``limit`` are the smallest of ``x``, so their order statistics are
    ``x``'s own. ``overwrite_input`` as in :func:`median`.
    """
    x = np.asarray(x, dtype=float)
    count = int(np.count_nonzero(x <= limit))
    if count < _SMALL or np.isnan(x).any():
        return float(np.median(x[x <= limit]))
    return _middle(x, count, overwrite_input)


def nanmedian(x: Float[np.ndarray, "n"]) -> float:
    """``float(np.nanmedian(x))`` of a 1-D array (NaN if it holds no number), without a warning."""
    x = np.asarray(x, dtype=float)
    nan = np.isnan(x)
    if nan.any():
        x = x[~nan]
    return median(x) if x.size else float("nan")


def quantile(x: Float[np.ndarray, "n"], q: float, overwrite_input: bool = False) -> float:
    """``float(np.quantile(x, q))`` of a 1-D array, NumPy's default ``"linear"`` method.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Values. NaN anywhere gives NaN, as in NumPy.
    q : float
        Probability in [0, 1].
    overwrite_input : bool
        As in :func:`median`.

    Returns
    -------
    float
    """
    x = np.asarray(x, dtype=float)
    if x.size < _SMALL or np.isnan(x).any() or not 0.0 <= q <= 1.0:
        return float(np.quantile(x, q))
    n = x.size
    # NumPy's "linear" method: virtual index (n - 1) q between ranks i and i + 1.
    virtual = (n - 1) * q
    lower = math.floor(virtual)
    if lower >= n - 1:
        return float(x.max())
    a, b = _ranks(x, lower, overwrite_input)
    gamma = virtual - lower
    diff = b - a
    # NumPy's _lerp: from the nearer end, so that gamma 0 and 1 give a and b exactly.
    if gamma >= 0.5:
        return float(b - diff * (1 - gamma))
    return float(a + diff * gamma)


def nanmedian_columns(x: Float[np.ndarray, "n *k"]) -> float | Float[np.ndarray, " k"]:
    """``np.nanmedian(x, axis=0)``: a float for 1-D ``x``, one value per column for 2-D."""
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        return nanmedian(x)
    return np.array([nanmedian(column) for column in x.T])


def median_of_four(x: Float[np.ndarray, "n 4"]) -> Float[np.ndarray, "n"]:
    """Row-wise median of four columns, (sum − min − max) / 2 (NaN if any is NaN).

    Column by column: a reduction along a row of four is ~10x slower in NumPy than the same
    arithmetic on whole columns. The sum is taken in ``x.sum(axis=1)``'s order.

    Examples
    --------
    >>> import numpy as np
    >>> median_of_four(np.array([[1.0, 4.0, 2.0, 3.0], [0.0, np.nan, 1.0, 1.0]]))
    array([2.5, nan])
    """
    a, b, c, d = (x[:, i] for i in range(4))
    total = a + b
    total += c
    total += d
    total -= np.minimum(np.minimum(a, b), np.minimum(c, d))
    total -= np.maximum(np.maximum(a, b), np.maximum(c, d))
    total *= 0.5
    return total


def _middle(x: np.ndarray, count: int, overwrite_input: bool = False) -> float:
    """np.median of the ``count`` smallest values of ``x`` (no NaN)."""
    half = count // 2
    if count % 2:
        return float(_ranks(x, half, overwrite_input)[0])
    a, b = _ranks(x, half - 1, overwrite_input)
    return float((a + b) / 2)  # np.median: the mean of the two middle values


def _ranks(x: np.ndarray, k: int, overwrite_input: bool = False) -> tuple[float, float]:
    """The (k+1)-th and (k+2)-th smallest values of ``x`` (0-based ranks k and k + 1)."""
    values, counts = np.unique(x[:: max(1, x.size // 500)], return_counts=True)
    sample = int(counts.sum())
    top = int(np.argmax(counts))
    if counts[top] * 4 >= sample:
        # One value holds a quarter of a strided sample (a quantised signal's second
        # differences: mostly 0). The SIMD selection degrades on such ties (~9 ms on 90,000
        # values); two counts find whether the ranks fall in the value's run.
        tied = _tied_ranks(x, k, values[top])
        if tied is not None:
            return tied
    if values.size * 4 < sample:
        # Few distinct values (time steps of a uniform clock): a full sort is faster there.
        if overwrite_input:
            x.sort()
            ordered = x
        else:
            ordered = np.sort(x)
        return ordered[k], ordered[min(k + 1, x.size - 1)]
    if overwrite_input:
        x.partition(k)
        part = x
    else:
        part = np.partition(x, k)
    return part[k], (part[k + 1 :].min() if k + 1 < x.size else part[k])


def _tied_ranks(x: np.ndarray, k: int, value: float) -> tuple[float, float] | None:
    """Ranks k and k + 1 of ``x`` where rank k is ``value`` (from counts, no reordering), or
    None where it is not."""
    below = int(np.count_nonzero(x < value))
    through = below + int(np.count_nonzero(x == value))
    if not below <= k < through:
        return None
    if k + 1 < through or k + 1 >= x.size:
        return value, value
    return value, np.min(x, where=x > value, initial=np.inf)
