"""Where the lateral fit reads a drive: its stretches, padded lengths, subsets for the search.

A drive longer than :data:`FIT_BLOCKS` 5 s stretches is fitted on that many of them: those with
the most cornering, and a quarter of the number spread evenly over the rest
(:func:`_fit_stretches`). Observations are padded to a few lengths (drives of any length share
a few compiled programs); a long drive's mode is searched on a fixed number of evenly spaced
stretches, its data scaled to the whole's weight, and refined on all samples
(:func:`~tyrebayes.inference.lateral.mode._weighted_mode`).
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from .data import CorneringObservations

#: Observations are padded to SEARCH_BLOCK times one of these numbers of blocks times a power of
#: two (at most a quarter more samples), so that drives of any length share a few compiled
#: programs instead of compiling one each.
_PADDED_BLOCKS = (4, 5, 6, 7)
#: Length of the stretches of a drive the search keeps [samples at 10 Hz]: the kinematic
#: equation differentiates V_x α_r along time, so the search reads whole 5 s stretches (their
#: two samples at each end left out of the equations) rather than every n-th sample.
SEARCH_BLOCK = 50
#: Samples the search for the weighted mode reads: a drive of more than 1.5 times as many is
#: searched on this many samples' worth of evenly spaced stretches, and the search's optimum
#: refined on all samples.
SEARCH_SAMPLES = 6000
#: Stretches a fit reads at most (21 min at 10 Hz): a fleet's drives of 20 to 60 min then share
#: one padded length, and one set of compiled programs, instead of one per quarter octave.
FIT_BLOCKS = 256
#: Of those, the share spread evenly over the drive's other stretches: straight driving fixes
#: the steering and a_y offsets, which cornering in one direction cannot tell from stiffness.
FIT_SPREAD_SHARE = 0.25
#: Samples the first search for the unweighted mode reads (:func:`_weighted_mode`): from
#: the priors' medians it takes the most BFGS steps of the fit, here each a quarter as dear.
INFLATION_SEARCH_SAMPLES = 1500


def padded_length(n: int) -> int:
    """The length a fit pads ``n`` observations to: SEARCH_BLOCK × m × 2^k, m in 4..7.

    Examples
    --------
    >>> padded_length(36000), padded_length(2390)
    (38400, 2400)
    """
    blocks = -(-n // SEARCH_BLOCK)
    k = 0
    while True:
        for m in _PADDED_BLOCKS:
            if m << k >= blocks:
                return SEARCH_BLOCK * (m << k)
        k += 1


_SERIES = (
    "speed", "yaw_rate", "yaw_acceleration", "ay", "steering", "mask", "mask_kinematic",
    "longitudinal", "ax",
)  # fmt: skip


def _padded(obs: CorneringObservations) -> CorneringObservations:
    """``obs`` padded to :func:`padded_length` with samples outside both masks."""
    n = obs.speed.shape[0]
    extra = padded_length(n) - n
    if extra == 0:
        return obs
    # Padding's speed stays away from zero: the equations divide by it before the mask applies.
    fill = {"speed": 10.0, "mask": False, "mask_kinematic": False, "longitudinal": False}

    def pad(name):
        x = np.asarray(getattr(obs, name))
        return np.concatenate([x, np.full(extra, fill.get(name, 0.0), x.dtype)])

    return _with_series(obs, {name: pad(name) for name in _SERIES})


def _with_series(obs: CorneringObservations, series: dict) -> CorneringObservations:
    """``obs`` with its series replaced by ``series`` (NumPy arrays).

    The cutting and padding run in NumPy: each eager JAX operation on a new length would compile
    a small program, and a fleet worker, meeting many lengths, would hold them all.
    """
    return dataclasses.replace(obs, **{k: jnp.asarray(v) for k, v in series.items()})


def _stretch_mask(blocks: int, chosen: np.ndarray) -> np.ndarray:
    """Samples of the ``chosen`` stretches (sorted block indices) that the equations may read:
    all but the two at an end whose neighbouring stretch was not chosen (a five-point derivative
    there would reach into it)."""
    keep = np.ones((chosen.size, SEARCH_BLOCK), bool)
    gap_before = np.r_[True, np.diff(chosen) > 1]
    gap_after = np.r_[np.diff(chosen) > 1, True]
    keep[gap_before, :2] = False
    keep[gap_after, -2:] = False
    return keep.reshape(-1)


def _stretches(
    obs: CorneringObservations, chosen: np.ndarray, keep: np.ndarray
) -> CorneringObservations:
    """The ``chosen`` stretches of ``obs`` (block indices), both masks cut to ``keep`` (one
    flag per sample of the result)."""
    n = obs.speed.shape[0] // SEARCH_BLOCK * SEARCH_BLOCK

    def take(x):
        return np.asarray(x)[:n].reshape(-1, SEARCH_BLOCK)[chosen].reshape(-1)

    series = {name: take(getattr(obs, name)) for name in _SERIES}
    series["mask"] = series["mask"] & keep
    series["mask_kinematic"] = series["mask_kinematic"] & keep
    return _with_series(obs, series)


def _fit_stretches(obs: CorneringObservations) -> CorneringObservations:
    """``obs`` cut to :data:`FIT_BLOCKS` stretches when it is longer: the posterior of those.

    The stretches are those with the largest Σ a_y² over the used samples (a stretch's
    information on the slip angles grows with the forces in it) and, for
    :data:`FIT_SPREAD_SHARE` of the number, evenly spaced ones among the rest. Choosing by the
    measured forces, not by the residuals, leaves the likelihood of the kept samples as it is;
    the fit is then that of 21 minutes of the drive (an interval as wide as those data give,
    not narrowed as if it had read all of them). ``cornering_seconds`` stays the drive's.

    Examples
    --------
    >>> from tyrebayes import load_vehicle
    >>> from tyrebayes.inference.lateral import cornering_observations
    >>> from tyrebayes.simulate import simulate_cornering
    >>> frame, _ = simulate_cornering(load_vehicle("compact_fwd"), duration_s=120.0, seed=1)
    >>> obs = cornering_observations(frame, load_vehicle("compact_fwd"))
    >>> _fit_stretches(obs) is obs
    True
    """
    blocks = obs.speed.shape[0] // SEARCH_BLOCK
    if blocks <= FIT_BLOCKS:
        return obs
    n = blocks * SEARCH_BLOCK
    mask = np.asarray(obs.mask)[:n].reshape(blocks, SEARCH_BLOCK)
    ay = np.asarray(obs.ay)[:n].reshape(blocks, SEARCH_BLOCK)
    score = np.where(mask, ay**2, 0.0).sum(axis=1)
    spread = int(FIT_SPREAD_SHARE * FIT_BLOCKS)
    order = np.argsort(-score, kind="stable")
    top, rest = order[: FIT_BLOCKS - spread], np.sort(order[FIT_BLOCKS - spread :])
    even = rest[((np.arange(spread) + 0.5) * rest.size / spread).astype(int)]
    chosen = np.sort(np.r_[top, even])
    return _stretches(obs, chosen, _stretch_mask(blocks, chosen))


def _search_blocks(n: int, samples: int | None = None) -> int | None:
    """How many stretches a search of about ``samples`` (default :data:`SEARCH_SAMPLES`) reads
    of ``n`` padded samples; ``None``: all of them (``n`` is under 1.5 times ``samples``).

    The count depends on ``samples`` only, not on the drive's length: every drive long enough to
    be searched on a subset is searched on subsets of the same shape, whose compiled programs a
    fleet worker reuses from drive to drive.

    Examples
    --------
    >>> _search_blocks(38400), _search_blocks(38400, 1500), _search_blocks(6400)
    (120, 30, None)
    """
    count = (SEARCH_SAMPLES if samples is None else samples) // SEARCH_BLOCK
    return count if n >= 1.5 * count * SEARCH_BLOCK else None


def _search_subset(obs: CorneringObservations, count: int) -> tuple[CorneringObservations, float]:
    """``count`` stretches of ``obs``, evenly spaced, and the data scale that gives them the
    whole's weight.

    The scale is the whole drive's used samples over the subset's, so that the subset's
    potential has the whole's curvature (its Hessian whitens the refinement on all samples).
    """
    blocks = obs.speed.shape[0] // SEARCH_BLOCK
    # the middle stretch of each of ``count`` equal parts of the drive
    chosen = ((np.arange(count) + 0.5) * blocks / count).astype(int)
    inner = np.ones(SEARCH_BLOCK, bool)
    inner[:2] = inner[-2:] = False
    # Each stretch's ends: the five-point derivatives there would reach into the next stretch.
    subset = _stretches(obs, chosen, np.tile(inner, count))
    scale = float(np.sum(np.asarray(obs.mask))) / max(float(np.sum(np.asarray(subset.mask))), 1.0)
    return subset, scale
