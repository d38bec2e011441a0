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

from .log_sample import sample_runs
from .order_stats import median, nanmedian_columns, quantile


def quantisation_step(x: Float[np.ndarray, "n"]) -> float:
    """Resolution of a quantised signal, or 0.0 when the values look continuous.

    The gaps between neighbouring distinct values of a signal encoded with step q are integer
    multiples of q. The smallest gap is taken as q and accepted only if 95 % of all gaps are
    within 10 % of a multiple of it.

    A long log is read in runs of consecutive samples (:mod:`.log_sample`): a signal that
    moves level by level shows neighbouring levels within a run.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Raw samples as logged (before any resampling, which blurs the steps); NaN ignored.

    Returns
    -------
    float
        Step in the unit of ``x``; 0.0 if no step is found.
    """
    finite = np.isfinite(x)
    values = x if finite.all() else x[finite]
    # np.unique's distinct values (sorted, first of each run of equal ones) from one sort.
    ordered = np.sort(sample_runs(values), axis=None)
    new = np.empty(ordered.shape, dtype=bool)
    new[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=new[1:])
    distinct = ordered[new]
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
    if quantile(off, 0.95) > 0.1:
        return 0.0
    unit_gaps = gaps[np.round(ratio) == 1]
    return median(unit_gaps)


def white_noise_sd(x: Float[np.ndarray, "n"], quantisation: float = 0.0) -> float:
    """Standard deviation of the sample-to-sample noise of a signal on a uniform time base.

    From the second difference: for white noise of sd s, ``Δ²x`` has sd ``s√6``, while smooth
    vehicle motion contributes almost nothing at 50-100 Hz. The median absolute deviation keeps
    spikes from dominating. Quantisation of step q adds ``q/√12`` (a step signal can give a zero
    MAD, which would claim a perfect sensor).

    A long log is read in runs of consecutive samples (:mod:`.log_sample`).

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
    runs = sample_runs(np.asarray(x, dtype=float))
    d2 = (runs[:, 2:] - 2.0 * runs[:, 1:-1] + runs[:, :-2]).ravel()
    d2 = d2[np.isfinite(d2)]
    if d2.size < 10:
        return float("nan")
    mad = median(np.abs(d2 - median(d2)), overwrite_input=True)
    sd = 1.4826 * mad / np.sqrt(6.0)
    return float(np.sqrt(sd**2 + quantisation**2 / 12.0))


def local_noise_sd(
    x: Float[np.ndarray, "n *k"],
    window: int,
    span: int,
    ratio: int = 5,
    clip: float = 5.0,
    prefix=None,
    like=None,
) -> Float[np.ndarray, "n *k"]:
    """Per-sample noise sd of a ``window``-sample moving average of ``x`` (coloured noise too).

    High-pass the signal by removing a ``ratio``·window moving average, smooth the residual
    like the feature is smoothed, and take its local root-mean-square over ``span`` samples. For
    white noise this recovers sd/√window after the factor 1/√(1 − 1/ratio) for the removed
    band; for correlated noise (resonances, vibration) it stays close to the true sd of the
    smoothed noise, where white-noise rules and block differences can be off by 2x. Values
    beyond ``clip`` times the log's robust scale are clipped (a gear shift is not noise).
    Road roughness and speed change the noise over seconds; ``span`` ~10 s follows that.

    Parameters
    ----------
    x : ndarray, shape (n,) or (n, k)
        Signal(s) along axis 0 with the vehicle motion removed where possible (e.g. R·Ω − V_x);
        NaN allowed.
    window : int
        Smoothing window of the feature [samples].
    span : int
        Averaging span of the local RMS [samples].
    prefix : PrefixSums or sequence of (PrefixSums or None), optional
        :class:`~tyrebayes.streams.filters.PrefixSums` of a 1-D ``x`` (of each column of a 2-D
        one, None where not at hand), when the caller has them: they are not formed again.
    like : PrefixSums, optional
        Prefix sums of another signal with, most likely, the first column's NaN: its counts
        are reused if the NaN agree (checked).

    Returns
    -------
    ndarray, same shape as ``x``
        Noise sd of the smoothed signal at each sample (NaN where no data is near).

    Examples
    --------
    >>> x = np.random.default_rng(0).normal(0, 1, 100_000)
    >>> round(float(np.nanmedian(local_noise_sd(x, 25, 1000))), 1)  # 1/sqrt(25)
    0.2
    """
    # Sibling leaf module; avoids an import cycle.
    from .filters import nan_moving_average, strided_window_mean

    x = np.asarray(x, dtype=float)
    if x.ndim > 2:
        return local_noise_sd(x.reshape(x.shape[0], -1), window, span, ratio, clip).reshape(x.shape)
    columns = [x] if x.ndim == 1 else [x[:, j] for j in range(x.shape[1])]
    if prefix is None or x.ndim == 1:
        given = [prefix] * len(columns)
    else:
        given = list(prefix)
        if len(given) != len(columns):
            raise ValueError(
                f"local_noise_sd: expected {len(columns)} prefix sums (one per column), "
                f"got {len(given)}"
            )
    long = ratio * window + (1 - (ratio * window) % 2)  # odd
    # The smoothed residual changes over a window, so every (window//2)-th sample carries its
    # information: it is formed at those samples only, and the robust scale and the ~10 s local
    # mean run on that thinned series.
    step = max(1, window // 2)
    thin, prefixes = [], None if like is None else (like, None)
    for column, own in zip(columns, given, strict=True):
        # Columns with the same dropped samples (the four slip velocities) share their counts.
        *prefixes, resid = _residual(column, long, like=prefixes, prefix=own)
        thin.append(strided_window_mean(resid, window // 2, prefixes[0], overwrite_input=True))
    finite = min(np.isfinite(t).sum() for t in thin)
    if finite < 10 and min(_finite_smoothed(c, window, long) for c in columns) < 10:
        return np.full(x.shape, np.nan)
    thin = thin[0] if x.ndim == 1 else np.array(thin).T
    scale = 1.4826 * nanmedian_columns(np.abs(thin))
    sq = np.minimum(thin**2, (clip * scale) ** 2)
    local = nan_moving_average(sq, max(1, span // step))
    # sqrt(local · gain) on the thinned series, then each value repeated over its step.
    root = np.sqrt(local * _white_gain(window, long))
    if x.ndim == 1:
        return np.repeat(root, step)[: x.shape[0]]
    out = np.empty(x.shape[::-1])  # columns contiguous, like the pipeline's tables
    for row, column in zip(out, root.T, strict=True):
        row[:] = np.repeat(column, step)[: x.shape[0]]
    return out.T


def _residual(x: np.ndarray, long: int, like: tuple | list | None = None, prefix=None) -> tuple:
    """Prefix sums of x and of MA(x), and the residual x − (2·MA(x) − MA(MA(x))), MA over ``long``.

    "Twicing" low-pass 2·MA − MA∘MA: flat to second order, so slow true signal (slip following
    the driver's torque) leaks ~10x less into the residual than with one moving average.
    ``like``: another column's prefixes, whose counts are reused where the NaN agree;
    ``prefix``: x's own, when the caller has them.
    """
    from .filters import PrefixSums

    if prefix is None:
        prefix = PrefixSums.of(x, like=like[0] if like else None)
    once = prefix.window_mean(long // 2)
    once_prefix = PrefixSums.of(once, like=like[1] if like else None)
    # The residual x − (2·once − MA(once)), in place; NaN where x is (the low-pass has a value
    # wherever x has one), so x's counts serve its moving average.
    resid = once_prefix.window_mean(long // 2)
    once *= 2.0
    resid -= once
    del once
    resid += x
    return prefix, once_prefix, resid


def _finite_smoothed(x: np.ndarray, window: int, long: int) -> int:
    """Number of samples where the smoothed residual has a value (all samples, not thinned)."""
    from .filters import PrefixSums

    prefix, _, resid = _residual(x, long)
    smooth = PrefixSums.of(resid, like=prefix).window_mean(window // 2)
    return int(np.isfinite(smooth).sum())


def _white_gain(window: int, long: int) -> float:
    """(1/window) / variance gain of the residual filter for white noise (exact, from kernels)."""
    box_w = np.ones(window) / window
    box_l = np.ones(long) / long
    low = 2.0 * np.convolve(box_l, [1.0]) - np.convolve(box_l, box_l)[long // 2 : long // 2 + long]
    delta = np.zeros(long)
    delta[long // 2] = 1.0
    kernel = np.convolve(delta - low, box_w)
    return (1.0 / window) / float(np.sum(kernel**2))
