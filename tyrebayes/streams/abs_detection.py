"""ABS detection: which windows of a stream are ABS stops (all four wheels cycling at the peak).

Signal processing on the stream's wheel speeds, ahead of inference: the per-tyre model's ABS
windows (:func:`tyrebayes.inference.observations_from_features`) observe μ_max directly.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Bool, Float

from .filters import nan_moving_average, window_samples


def window_means(
    values: np.ndarray, valid: np.ndarray, window: int
) -> tuple[np.ndarray, np.ndarray]:
    """Means of consecutive blocks of ``window`` samples and the number of valid samples in each."""
    n_blocks = len(values) // window
    v = np.where(valid, values, 0.0)[: n_blocks * window].reshape(n_blocks, window)
    counts = valid[: n_blocks * window].reshape(n_blocks, window).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        means = v.sum(axis=1) / counts
    return means, counts


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
    relative = wheel_vx_mps - np.mean(wheel_vx_mps, axis=1, keepdims=True)
    relative = relative - nan_moving_average(relative, window_samples(0.5, sample_rate_hz))
    ok = valid & np.all(np.isfinite(relative), axis=1)
    return np.max(
        np.column_stack([_window_sd(relative[:, i], ok, window) for i in range(4)]), axis=1
    )


def _window_sd(values: np.ndarray, valid: np.ndarray, window: int) -> np.ndarray:
    """Standard deviation within consecutive blocks of ``window`` samples (valid samples only)."""
    mean, counts = window_means(values, valid, window)
    n_blocks = len(mean)
    v = np.where(valid, values, 0.0)[: n_blocks * window].reshape(n_blocks, window)
    ok = valid[: n_blocks * window].reshape(n_blocks, window)
    with np.errstate(invalid="ignore", divide="ignore"):
        var = np.where(ok, (v - mean[:, None]) ** 2, 0.0).sum(axis=1) / counts
    return np.sqrt(var)


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
