"""ABS detection: which windows of a stream are ABS stops (all four wheels cycling at the peak).

Signal processing on the stream's wheel speeds, ahead of inference: the per-tyre model's ABS
windows (:func:`tyrebayes.inference.observations_from_features`) observe μ_max directly.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Bool, Float

from .filters import nan_moving_average, window_samples


def window_means(
    values: np.ndarray, valid: np.ndarray, window: int, counts: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Means of consecutive blocks of ``window`` samples and the number of valid samples in each.

    ``counts``: :func:`window_counts` of ``valid``, when the caller has them (several channels
    averaged over the same valid samples count them once).
    """
    n_blocks = len(values) // window
    end = n_blocks * window
    v = np.where(valid[:end], values[:end], 0.0).reshape(n_blocks, window)
    if counts is None:
        counts = window_counts(valid, window)
    with np.errstate(invalid="ignore", divide="ignore"):
        means = v.sum(axis=1) / counts
    return means, counts


def window_counts(valid: np.ndarray, window: int) -> np.ndarray:
    """Number of valid samples in each block of :func:`window_means`."""
    n_blocks = len(valid) // window
    return valid[: n_blocks * window].reshape(n_blocks, window).sum(axis=1)


def wheel_oscillation(
    wheel_vx_mps: Float[np.ndarray, "n 4"],
    valid: Bool[np.ndarray, "n"],
    window: int,
    sample_rate_hz: float,
) -> Float[np.ndarray, "m"]:
    """How much the wheels' speeds cycle within each window: the ABS detector's statistic [m/s].

    Each wheel's speed relative to the four-wheel mean (in m/s rather than slip: at low speed
    slip noise grows as 1/V and would look like ABS), high-passed by taking off its 0.5 s moving
    average, then its sd within each window; the largest of the four wheels. ABS drives the
    wheel speeds up and down several times a second, and that passes; a hard stop without ABS
    only ramps the wheels apart (their slips differ), which a window's plain sd reads as
    oscillation too (a 0.7 g stop in recovery seed 1003, brush_no_abs, made two ABS windows
    and put μ_max at −32 %), and that the high-pass removes.
    """
    # Column by column (the table's columns are contiguous): the four-wheel mean in np.mean's
    # order, and one masked copy and one count per block shared by the four wheels' sds.
    wheels = [wheel_vx_mps[:, i] for i in range(4)]
    mean = wheels[0] + wheels[1]
    mean += wheels[2]
    mean += wheels[3]
    mean /= 4
    relative = np.empty(wheel_vx_mps.shape[::-1]).T
    for i, wheel in enumerate(wheels):
        np.subtract(wheel, mean, out=relative[:, i])
    relative -= nan_moving_average(relative, window_samples(0.5, sample_rate_hz))
    ok = valid.copy()
    for i in range(4):
        ok &= np.isfinite(relative[:, i])
    counts = window_counts(ok, window)
    largest = _window_sd(relative[:, 0], ok, window, counts)
    for i in range(1, 4):
        np.maximum(largest, _window_sd(relative[:, i], ok, window, counts), out=largest)
    return largest


def _window_sd(
    values: np.ndarray, valid: np.ndarray, window: int, counts: np.ndarray
) -> np.ndarray:
    """Standard deviation within consecutive blocks of ``window`` samples (valid samples only).

    ``counts``: :func:`window_counts` of ``valid``.
    """
    n_blocks = len(counts)
    end = n_blocks * window
    v = np.where(valid[:end], values[:end], 0.0).reshape(n_blocks, window)
    ok = valid[:end].reshape(n_blocks, window)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = v.sum(axis=1) / counts
        v -= mean[:, None]
        v *= v
        var = np.where(ok, v, 0.0).sum(axis=1) / counts
    return np.sqrt(var, out=var)


# An ABS window's force is within a few percent of the event's (the controller holds the tyres
# near their peak); one well short of it is still in the entry ramp (one window at 0.83 of its
# event's force in four simulated drives with the ramp-free oscillation statistic).
_ABS_RUN_FORCE_SHARE = 0.9


def _below_run_peak(at_limit: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """``at_limit`` without windows whose |ρ| is under 0.9 of their run's median |ρ|."""
    start = at_limit & ~np.concatenate([[False], at_limit[:-1]])
    run = np.cumsum(start)
    keep = at_limit.copy()
    for r in np.unique(run[at_limit]):
        members = at_limit & (run == r)
        keep[members] = np.abs(rho[members]) >= _ABS_RUN_FORCE_SHARE * np.median(
            np.abs(rho[members])
        )
    return keep


def _inner_runs(flags: np.ndarray, min_run: int) -> np.ndarray:
    """Flags of runs of at least ``min_run`` consecutive True values, without each run's ends."""
    out = np.zeros_like(flags)
    padded = np.concatenate([[False], flags, [False]])
    change = np.flatnonzero(np.diff(padded.astype(int)))
    for start, stop in zip(change[::2], change[1::2], strict=True):
        if stop - start >= min_run:
            out[start + 1 : stop - 1] = True
    return out
