"""Criticism of a fitted per-tyre model (a fit file): its slip residuals against the conditions.

The per-tyre model (:func:`tyrebayes.inference.fit_tyre`, thesis eq. 4.27 read backwards: the
measured slip regressed on the measured force through the tyre curve, with slip offsets per 5 s
block) predicts each window's slip. Its fit file holds the posterior predictive draws of the slip
and, per window, the conditions the drive was in. This module scans the residuals

    e_i = sigma_obs,i - E[sigma_rep,i | data]

(slip windows only; ABS windows observe no slip) against those conditions with the calibrated
discovery rule of :mod:`.scan`, and checks the slip's posterior predictive distribution.

Candidates, where the fit's data hold them: the normalised force rho_x (the driven axle's
acceleration demand, and with it the load transfer), the tyre temperature, the time in the drive
(5 s block resolution), the drive (day) and the surface. Speed is not stored in a per-tyre fit
file; ``tyrebayes criticize-stream`` scans it on the stream itself.

Neighbouring windows share slip errors (the features' smoothing; the fit's
``slip_variance_inflation``), so the scan keeps every k-th slip window of a drive, k the drive's
variance inflation rounded up: the kept windows are about as informative as independent ones,
which the permutations assume. Permutations stay within a drive.
"""

from __future__ import annotations

import json
import math
import os

import numpy as np

from .._errors import BadInputError
from ..inference.result import Fit
from ..inference.tyre.data import BLOCK_S
from ..inference.tyre.predictive import with_pointwise
from .fleet_fit import _as_fit
from .linear import loo_from_pointwise, psis_loo_pointwise
from .permutation import DEFAULT_PERMUTATIONS
from .ppc import posterior_predictive_check
from .scan import DEFAULT_ALPHA, ELPD_SE_FACTOR, Candidate, CriticismResult, criticize_linear

#: Prior variance of the per-drive intercepts of the residual model (units of its sd^2).
_PRIOR_VAR_INTERCEPT = 100.0
#: Fewest kept windows the scan needs.
_MIN_WINDOWS = 12


def _numeric(name: str, values: np.ndarray) -> Candidate | None:
    """A standardised numeric candidate (None where the values do not vary)."""
    finite = values[np.isfinite(values)]
    if finite.size < 3 or np.ptp(finite) <= 1e-12 * max(1.0, float(np.abs(finite).max())):
        return None
    sd = float(np.std(finite))
    return Candidate(
        name, "numeric", ((values - finite.mean()) / sd)[:, None], np.array([sd]), (name,)
    )


def _categorical(name: str, labels: np.ndarray, names: list[str]) -> Candidate | None:
    """Indicator columns of each level against the commonest (None for a single level)."""
    levels, counts = np.unique(labels, return_counts=True)
    if levels.size < 2:
        return None
    ref = levels[np.argmax(counts)]
    others = [lev for lev in levels if lev != ref]
    cols = np.column_stack([(labels == lev).astype(float) for lev in others])
    return Candidate(
        name,
        "categorical",
        cols,
        np.ones(len(others)),
        tuple(f"{names[lev]} vs {names[ref]}" for lev in others),
    )


def _thinned_slip_windows(fit: Fit, at_limit: np.ndarray, drive: np.ndarray) -> np.ndarray:
    """Every k-th slip window of each drive, k its slip variance inflation rounded up."""
    inflation = json.loads(fit.data.attrs.get("slip_variance_inflation", "[]"))
    keep = []
    for d in np.unique(drive):
        rows = np.flatnonzero((drive == d) & ~at_limit)
        k = max(1, math.ceil(float(inflation[d]))) if d < len(inflation) else 1
        keep.append(rows[::k])
    return np.sort(np.concatenate(keep)) if keep else np.zeros(0, int)


def criticize_tyre_fit(
    fit: Fit | str | os.PathLike,
    *,
    alpha: float = DEFAULT_ALPHA,
    seed: int = 0,
    n_draws: int = 2000,
    n_permutations: int = DEFAULT_PERMUTATIONS,
    se_factor: float = ELPD_SE_FACTOR,
) -> CriticismResult:
    """Criticise a per-tyre fit: slip residuals against the drive's conditions, and its PPC.

    Parameters
    ----------
    fit : Fit or path
        A per-tyre fit (``kind="tyre"``) or its file (``tyrebayes fit-tyre --out FIT.nc``).
    alpha, seed, n_draws, n_permutations, se_factor
        As in :func:`tyrebayes.criticism.criticize_table`.

    Returns
    -------
    CriticismResult
        ``baseline``: the fit's PSIS-LOO of the measured slip (slip windows); candidates with
        effect (slip per unit of the condition, 90 % HDI), permutation p, BH q, ELPD gain of
        the residual model extended by the condition and its SE, found; posterior predictive
        checks of the slip; notes.

    Raises
    ------
    BadInputError
        Not a per-tyre fit, or too few slip windows to scan.

    Examples
    --------
    >>> from tyrebayes.inference.tyre.data import observations_from_stream  # doctest: +SKIP
    >>> from tyrebayes.inference import fit_tyre  # doctest: +SKIP
    >>> from tyrebayes._resources import data_dir  # doctest: +SKIP
    >>> obs = observations_from_stream(  # doctest: +SKIP
    ...     data_dir() / "comma2k19_rav4_segment.csv", "suv_rav4"
    ... )
    >>> criticize_tyre_fit(fit_tyre(obs, method="fast").fit).found  # doctest: +SKIP
    []
    """
    fit = _as_fit(fit, "tyre")
    if fit.kind != "tyre":
        raise BadInputError(f"fit: expected a tyre fit, got a {fit.kind} fit")
    # A fit saved without its per-window draws (a fleet run's) gets them recomputed.
    fit = with_pointwise(fit)
    const = fit.data["constant_data"]
    slip = np.asarray(fit.data["observed_data"]["slip_obs"], float)
    rho = np.asarray(fit.data["observed_data"]["rho_obs"], float)
    n = slip.shape[0]
    at_limit = np.asarray(const["at_limit"], bool)
    drive = _window(const, "drive_index", np.zeros(n, int)).astype(int)
    y_rep = np.asarray(fit.data["posterior_predictive"]["slip_obs"], float).reshape(-1, n)
    rows = _thinned_slip_windows(fit, at_limit, drive)
    if rows.shape[0] < _MIN_WINDOWS:
        raise BadInputError(
            f"tyre fit: expected at least {_MIN_WINDOWS} slip windows to criticise, got "
            f"{rows.shape[0]} after thinning"
        )
    pred = y_rep.mean(axis=0)
    resid = (slip - pred)[rows]
    scale = float(np.std(resid))
    scale = scale if scale > 0 else 1.0

    candidates, notes = _condition_candidates(fit, const, rho, drive, rows)
    drives = np.unique(drive[rows], return_inverse=True)[1]
    onehot = np.eye(int(drives.max()) + 1)[drives]
    if onehot.shape[1] > 1:
        names = [f"drive {d}" for d in range(onehot.shape[1])]
        extra = _categorical("drive", drives, names)
        candidates.append(extra)
        # The drive is then a candidate itself: the baseline is one intercept.
        onehot = np.ones((rows.shape[0], 1))
    _, _, results, found, scan_notes = criticize_linear(
        resid / scale,
        onehot,
        np.full(onehot.shape[1], _PRIOR_VAR_INTERCEPT),
        candidates,
        y_scale=scale,
        strata=np.zeros(rows.shape[0], int) if onehot.shape[1] == 1 else drives,
        alpha=alpha,
        seed=seed,
        n_draws=n_draws,
        n_permutations=n_permutations,
        se_factor=se_factor,
    )
    slip_windows = ~at_limit
    baseline, ppc = _slip_loo_and_ppc(fit, slip, y_rep, pred, slip_windows)
    notes = [
        f"fitted model: per-tyre fit ({fit.provenance.method}, {fit.provenance.model}; "
        f"converged {fit.converged}, adequate {fit.adequate}); PSIS-LOO of the slip "
        f"{baseline.elpd:.1f} (SE {baseline.se:.1f}) over {int(slip_windows.sum())} windows, "
        f"{baseline.n_k_high} with Pareto k > 0.7",
        f"residual scan on {rows.shape[0]} slip windows (every k-th of a drive, k its slip "
        "variance inflation); speed is not in a per-tyre fit file (criticize-stream scans it)",
        *notes,
        *scan_notes,
    ]
    return CriticismResult(
        baseline=baseline,
        candidates=results,
        found=found,
        ppc=ppc,
        notes=notes,
        alpha=alpha,
        n_permutations=n_permutations,
    )


def _window(const, name: str, default):
    """A per-window variable of the fit's constant data (``default`` where it is not stored)."""
    return np.asarray(const[name]) if name in const.data_vars else default


def _condition_candidates(
    fit: Fit, const, rho: np.ndarray, drive: np.ndarray, rows: np.ndarray
) -> tuple[list[Candidate], list[str]]:
    """The conditions the fit file holds, at the kept windows, as candidates; notes on gaps."""
    candidates = [_numeric("force_rho", rho[rows])]
    notes = []
    if "temperature_c" in const.data_vars:
        candidates.append(
            _numeric("tyre_temperature_c", _window(const, "temperature_c", None)[rows])
        )
    else:
        notes.append("the fit file holds no window temperatures (made before they were stored)")
    if "block_index" in const.data_vars:
        block = _window(const, "block_index", None).astype(int)
        first = np.array([block[drive == d].min() for d in range(int(drive.max()) + 1)])
        candidates.append(_numeric("time_in_drive_s", BLOCK_S * (block - first[drive])[rows]))
    surfaces = json.loads(fit.data.attrs.get("surfaces", "[]"))
    if "surface_index" in const.data_vars and surfaces:
        candidates.append(
            _categorical(
                "surface", _window(const, "surface_index", None).astype(int)[rows], surfaces
            )
        )
    return [c for c in candidates if c is not None], notes


def _slip_loo_and_ppc(
    fit: Fit, slip: np.ndarray, y_rep: np.ndarray, pred: np.ndarray, slip_windows: np.ndarray
):
    """The fit's PSIS-LOO of the slip windows, and the slip's posterior predictive checks."""
    n = slip.shape[0]
    loglik = np.asarray(fit.data["log_likelihood"]["slip_obs"], float).reshape(-1, n)
    elpd_i, k = psis_loo_pointwise(loglik[:, slip_windows])
    baseline = loo_from_pointwise(elpd_i, k, 0)
    ppc = posterior_predictive_check(slip[slip_windows], y_rep[:, slip_windows]).to_dict()
    r_obs = slip[None, slip_windows] - pred[slip_windows]
    r_rep = y_rep[:, slip_windows] - pred[slip_windows]
    t_obs, t_rep = _lag1(r_obs)[0], _lag1(r_rep)
    ppc["lag-1 autocorrelation of slip residuals"] = {
        "observed": float(t_obs),
        "p_value": float(np.mean(t_rep >= t_obs)),
    }
    return baseline, ppc


def _lag1(r: np.ndarray) -> np.ndarray:
    """Lag-1 autocorrelation of each row of ``r`` (over its last axis)."""
    c = r - r.mean(axis=-1, keepdims=True)
    return (c[..., 1:] * c[..., :-1]).sum(axis=-1) / np.maximum((c**2).sum(axis=-1), 1e-300)
