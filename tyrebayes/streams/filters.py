"""NaN-aware smoothing and differentiation on a uniform time base (vectorised NumPy).

Dropped samples are NaN; these filters average over the valid samples in each window instead of
spreading NaN, and return NaN only where a window holds no valid sample at all.

Examples
--------
>>> import numpy as np
>>> x = np.array([1.0, np.nan, 3.0, 4.0, 5.0])
>>> nan_moving_average(x, 3).round(2).tolist()
[1.0, 2.0, 3.5, 4.0, 4.5]
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Float


def nan_moving_average(x: Float[np.ndarray, "n *k"], window: int) -> Float[np.ndarray, "n *k"]:
    """Centred moving average over ``window`` samples (odd; even is rounded up), ignoring NaN.

    Parameters
    ----------
    x : ndarray, shape (n,) or (n, k)
        Signal(s) on a uniform time base along axis 0; NaN marks a missing sample.
    window : int
        Window length in samples (>= 1).

    Returns
    -------
    ndarray, same shape as ``x``
        Mean of the valid samples within ±window//2 of each sample; NaN where there are none.
        Windows are truncated at the ends. A 2-D result has contiguous columns.
    """
    if window < 1:
        raise ValueError(f"nan_moving_average: expected window >= 1, got {window}")
    x = np.asarray(x, dtype=float)
    half = window // 2
    if x.ndim == 1:
        return PrefixSums.of(x).window_mean(half)
    if x.ndim > 2:
        return nan_moving_average(x.reshape(x.shape[0], -1), window).reshape(x.shape)
    # Column by column (each contiguous, as the pipeline's tables are): columns with the same
    # dropped samples (e.g. the four slip velocities, NaN where the car stands) share one
    # cumulative count.
    out = np.empty(x.shape[::-1]).T
    previous = None
    for j in range(x.shape[1]):
        previous = PrefixSums.of(x[:, j], like=previous)
        previous.window_mean(half, out=out[:, j])
    return out


class PrefixSums:
    """Zero-led cumulative sums of a signal's valid values and of its valid-sample counts.

    Every window sum is then one difference of two entries: O(n) for any window. Physical
    signals (|x| < 1e3) keep ~1e-6 absolute precision over 1e7 samples in float64. Counts are
    integers (exact; a boolean's integer cumulative sum is the cheap one), and absent when
    every sample is valid.

    Attributes
    ----------
    values : ndarray, shape (n + 1,)
    counts : ndarray of int32, shape (n + 1,), or None when no sample is NaN
    valid : ndarray of bool, shape (n,), or None when no sample is NaN
    """

    __slots__ = ("values", "counts", "valid")

    def __init__(self, values, counts, valid):
        self.values, self.counts, self.valid = values, counts, valid

    @classmethod
    def of(cls, x: Float[np.ndarray, "n"], like: PrefixSums | None = None) -> PrefixSums:
        """Prefix sums of a 1-D signal; the counts are taken from ``like`` when its valid
        samples are the same (one comparison instead of a cumulative sum)."""
        buffer = cls.buffer(x.shape[0])
        np.copyto(buffer[1:], x)
        return cls.in_place(buffer, like)

    @staticmethod
    def buffer(n: int) -> Float[np.ndarray, " m"]:
        """A zero-led buffer for :meth:`in_place`: write the signal into ``buffer[1:]``."""
        values = np.empty(n + 1)
        values[0] = 0.0
        return values

    @classmethod
    def in_place(cls, buffer: Float[np.ndarray, " m"], like: PrefixSums | None = None):
        """Prefix sums of the signal in ``buffer[1:]``, formed in the buffer itself.

        The dropped samples are zeroed and summed where they lie: no temporary the size of
        the signal (fresh memory costs page faults, often more than the arithmetic).
        """
        body = buffer[1:]
        valid = np.isfinite(body)
        if valid.all():
            np.cumsum(body, out=body)
            return cls(buffer, None, None)
        np.copyto(body, 0.0, where=~valid)
        np.cumsum(body, out=body)
        if like is not None and like.valid is not None and np.array_equal(valid, like.valid):
            return cls(buffer, like.counts, like.valid)
        return cls(buffer, _cumsum0(valid, np.int32), valid)

    def window_mean(
        self, half: int, step: int = 1, out: np.ndarray | None = None
    ) -> Float[np.ndarray, "m"]:
        """Mean of the valid samples in [i − half, i + half] for every ``step``-th sample i.

        With ``step`` 1 the interior, where windows are whole, is two slices and only the
        2·half end rows get their own (truncated) bounds; with a larger step the window sums
        are gathered at the rows wanted. Both give the same numbers. ``out``: where to write
        them (step 1 only).
        """
        n = self.values.shape[0] - 1
        if step == 1:
            total = _window_difference(self.values, n, half, out=out)
        else:
            rows = np.arange(0, n, step)
            total = _gathered_difference(self.values, rows, n, half)
        if self.counts is None:
            # Whole windows hold `window` samples: one in-place division, then rescale the ends.
            total /= 2 * half + 1
            if not half:
                return total
            if step == 1 and n > 2 * half:
                edge = np.arange(half + 1, 2 * half + 1, dtype=float)  # counts of rows 0..half-1
                scale = (2 * half + 1) / edge
                total[:half] *= scale
                total[n - half :] *= scale[::-1]
                return total
            rows = np.arange(n) if step == 1 else rows
            count = (np.minimum(rows + half, n - 1) - np.maximum(rows - half, 0) + 1).astype(float)
            truncated = count < 2 * half + 1
            total[truncated] *= (2 * half + 1) / count[truncated]
            return total
        if step == 1:
            count = _window_difference(self.counts, n, half)
        else:
            count = _gathered_difference(self.counts, rows, n, half)
        # A window without a valid sample sums exactly 0 (its cumulative sums are equal): 0/0
        # makes it NaN with no pass of its own.
        with np.errstate(invalid="ignore", divide="ignore"):
            np.divide(total, count, out=total)
        return total

    def smoothed_derivative(self, half: int, dt_s: float) -> Float[np.ndarray, "n"]:
        """:func:`smoothed_derivative` with a ``2·half + 1`` window, from these sums."""
        return _derivative(self.window_mean(half), dt_s)


def strided_window_mean(
    x: Float[np.ndarray, "n"], half: int, like: PrefixSums, overwrite_input: bool = False
) -> Float[np.ndarray, " m"]:
    """``nan_moving_average(x, 2·half + 1)[::half]`` from segment sums, with no cumulative sum.

    The window of sample k·half is the segments [(k − 1)·half, k·half) and [k·half,
    (k + 1)·half) and the sample (k + 1)·half, so one ``np.add.reduceat`` over segments of
    ``half`` samples gives every window in two additions: a third of a cumulative sum's time.
    The numbers are the moving average's to rounding (the additions come in another order).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Signal; NaN marks a missing sample.
    half : int
        Half-window and stride [samples].
    like : PrefixSums
        Prefix sums of a signal with the same NaN as ``x`` (their counts are used); if the
        NaN differ, or ``half`` is 0, the moving average's own path is taken.
    overwrite_input : bool
        Let the NaN of ``x`` be zeroed in place (for a caller's temporary).
    """
    n = x.shape[0]
    valid = np.isfinite(x)
    all_valid = bool(valid.all())
    if all_valid:
        same = like.valid is None
    else:
        same = like.valid is not None and np.array_equal(valid, like.valid)
    if half < 1 or not same:
        return PrefixSums.of(x, like=like).window_mean(half, max(1, half))
    if not all_valid:
        if overwrite_input:
            np.copyto(x, 0.0, where=~valid)
        else:
            x = np.where(valid, x, 0.0)
    rows = np.arange(0, n, half)
    segments = np.add.reduceat(x, rows)
    total = segments.copy()
    total[1:] += segments[:-1]
    last = rows + half
    inside = last < n
    total[inside] += x[last[inside]]
    if all_valid:
        count = np.minimum(rows + half, n - 1) - np.maximum(rows - half, 0) + 1
    else:
        count = _gathered_difference(like.counts, rows, n, half)
    # A window without a valid sample sums exactly 0: 0/0 makes it NaN.
    with np.errstate(invalid="ignore", divide="ignore"):
        total /= count
    return total


def _cumsum0(x: np.ndarray, dtype=np.float64) -> np.ndarray:
    """Cumulative sum along axis 0 with a zero row in front (shape n + 1)."""
    out = np.empty((x.shape[0] + 1,) + x.shape[1:], dtype=dtype)
    out[0] = 0
    np.cumsum(x, axis=0, out=out[1:])
    return out


def _window_difference(
    csum: np.ndarray, n: int, half: int, out: np.ndarray | None = None
) -> np.ndarray:
    """Sum over the window [i − half, i + half] ∩ [0, n) from a zero-led cumulative sum."""
    if n <= 2 * half:  # every window truncated: index arrays, cheap at this size
        idx = np.arange(n)
        return np.subtract(
            csum[np.minimum(idx + half + 1, n)], csum[np.maximum(idx - half, 0)], out=out
        )
    if out is None:
        out = np.empty((n,) + csum.shape[1:], dtype=csum.dtype)
    np.subtract(csum[2 * half + 1 :], csum[: n - 2 * half], out=out[half : n - half])
    if half:
        out[:half] = csum[half + 1 : 2 * half + 1]  # minus csum[0] = 0
        out[n - half :] = csum[n] - csum[n - 2 * half : n - half]
    return out


def _gathered_difference(csum: np.ndarray, rows: np.ndarray, n: int, half: int) -> np.ndarray:
    """:func:`_window_difference` at the given rows only (the same differences)."""
    return csum[np.minimum(rows + half + 1, n)] - csum[np.maximum(rows - half, 0)]


def smoothed_derivative(
    x: Float[np.ndarray, "n"], dt_s: float, window: int
) -> Float[np.ndarray, "n"]:
    """Time derivative of ``x`` after a NaN-aware moving average of ``window`` samples [unit/s].

    A boxcar followed by a central difference: the noise gain is about ``sd / (window dt)``
    instead of ``sd / dt`` for the raw difference.
    """
    return _derivative(nan_moving_average(x, window), dt_s)


def _derivative(smooth: np.ndarray, dt_s: float) -> np.ndarray:
    if smooth.shape[0] < 2:
        return np.full_like(smooth, np.nan)
    return np.gradient(smooth, dt_s)


def window_samples(seconds: float, sample_rate_hz: float) -> int:
    """Odd number of samples spanning about ``seconds`` at ``sample_rate_hz`` (at least 1)."""
    n = max(1, int(round(seconds * sample_rate_hz)))
    return n if n % 2 == 1 else n + 1
