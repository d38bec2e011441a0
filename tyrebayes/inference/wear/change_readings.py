"""Tread readings decide a tyre change's type where the radius ratio cannot.

:func:`~tyrebayes.inference.wear.changepoint.detect_tyre_changes` tells a rotation from a
replacement by the size of the radius ratio's step against the drift before it; where the axles
wore nearly alike, or the new tyres' radii differ by as much as the drift, both read alike and
the more likely one can be wrong by a coin's toss. The type decides which tyre pair a later
reading measures: a rotated, worn pair taken as new at 8 mm reads as fast wear, and γ with it.

The readings tell them apart. For each assignment of types to the changes, the readings'
likelihood is their multivariate normal (each pair's new depth N(d0, sd²) shared by its
readings, the gauge's noise) with the tread lost at γ per joule of the history's work (both
components, eq. 4.19a + b), integrated over log γ on a grid under its prior; an assignment under
which a pair's readings grow is impossible. Its posterior is that likelihood times the ratio
test's own odds (each change's reported probability, independent), and each change gets the
type of the most probable assignment, with its marginal probability.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.linalg import solve_triangular
from scipy.special import logsumexp

from ..._errors import BadInputError
from .data import WearPriors
from .history import DriveHistory, TreadReadings, reading_exposure

#: Changes whose types are enumerated jointly (2^k assignments); beyond, the least certain k.
MAX_ENUMERATED_CHANGES = 6
#: Grid over log γ of the readings' likelihood: ± this many prior sds, this many points.
GRID_SDS, GRID_POINTS = 4.0, 321


def classify_changes_by_readings(
    history: DriveHistory,
    readings: TreadReadings,
    *,
    new_depth_mm: float,
    new_depth_sd_mm: float,
    wear_area_mm2: float,
    priors: WearPriors | None = None,
) -> DriveHistory:
    """``history`` with each change's type and probability given the tread readings too.

    Parameters
    ----------
    history : DriveHistory
        Through the latest reading (:meth:`DriveHistory.through`).
    readings : TreadReadings
    new_depth_mm, new_depth_sd_mm : float
        A new tyre's depth and its spread [mm].
    wear_area_mm2 : float
        The tread's wear area [mm²].
    priors : WearPriors, optional
        γ's prior (median, log-sd) and the gauge noise's median.

    Returns
    -------
    DriveHistory
        The same history where no change or no reading is; otherwise with the types of the
        most probable assignment and each change's marginal probability of its type. Raises
        the detected layout's :class:`~tyrebayes.BadInputError` when no assignment admits the
        readings.
    """
    changes = history.changes
    m = len(changes.change_type)
    if m == 0 or readings.depth_mm.size == 0:
        return history
    priors = WearPriors() if priors is None else priors
    p_reported = np.clip(np.asarray(changes.probability, dtype=float), 1e-12, 1.0 - 1e-12)
    free = np.argsort(p_reported)[:MAX_ENUMERATED_CHANGES]
    loss_per_gamma = (history.work_j + history.work_y_j) / 2.0 / wear_area_mm2  # (n, 2)
    z = np.linspace(-GRID_SDS, GRID_SDS, GRID_POINTS)  # log γ in prior sds from its median
    grid = np.log(priors.gamma_median_mm3_per_j) + priors.gamma_log_sd * z
    log_prior_gamma = -0.5 * z**2 - logsumexp(-0.5 * z**2)
    depth = np.asarray(readings.depth_mm, dtype=float)
    layouts, log_post = [], []
    for flip in itertools.product((False, True), repeat=free.size):
        types = list(changes.change_type)
        log_odds = np.log(p_reported)
        for i, f in zip(free, flip, strict=True):
            if f:
                types[i] = "replacement" if types[i] == "rotation" else "rotation"
                log_odds[i] = np.log1p(-p_reported[i])
        candidate = history.with_change_types(tuple(types), np.ones(m))
        try:
            exposure, pair = reading_exposure(candidate, readings)
        except BadInputError:  # a pair's readings grow under these types
            continue
        lost = np.einsum("mja,ja->m", exposure, loss_per_gamma)  # mm per (mm³/J)
        same = (pair[:, None] == pair[None, :]).astype(float)
        cov = new_depth_sd_mm**2 * same + priors.depth_noise_scale_mm**2 * np.eye(pair.size)
        # depth ~ N(new − γ lost, cov) at every γ of the grid at once, through one Cholesky
        chol = np.linalg.cholesky(cov)
        base = solve_triangular(chol, depth - new_depth_mm, lower=True)
        slope = solve_triangular(chol, lost, lower=True)
        white = base[None, :] + np.exp(grid)[:, None] * slope[None, :]
        log_lik = -0.5 * np.sum(white**2, axis=1) - np.sum(np.log(np.diag(chol)))
        log_lik -= 0.5 * depth.size * np.log(2.0 * np.pi)
        layouts.append(tuple(types))
        log_post.append(logsumexp(log_lik + log_prior_gamma) + float(log_odds.sum()))
    if not layouts:
        reading_exposure(history, readings)  # raises the detected layout's error
    weight = np.exp(np.asarray(log_post) - logsumexp(log_post))
    best = layouts[int(np.argmax(weight))]
    agrees = np.array([[lay[i] == best[i] for i in range(m)] for lay in layouts])
    probability = weight @ agrees
    return history.with_change_types(best, probability)


__all__ = ["classify_changes_by_readings"]
