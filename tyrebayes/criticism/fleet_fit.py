"""Criticism of a fitted hierarchical fleet model (a fit file) against its fleet table.

The fleet fit (:func:`tyrebayes.inference.fleet.fit_fleet`) is criticised as it was fitted —
latent stiffness with its measurement error, per-type slopes and noise scales — rather than
through a simplified refit:

* **Posterior predictive checks** from the fit's own ``posterior_predictive`` group: mean, sd,
  min, max and skewness of the outcome per surface, the sd per tyre type, and the realised
  discrepancy |corr(residual, candidate)| of every numeric candidate over the posterior draws.
* **Residual scan**: the residuals e_i = y_i - E[mean_i | data] of the fitted model (posterior
  mean of each row's predictive mean, thesis Fig 6.1 line through the latent C_xr) against every
  other column of the table, with the calibrated discovery rule of :mod:`.scan`: permutation
  p-values (residuals permuted within surface x tyre type, where the model has one noise scale),
  Benjamini-Hochberg over candidates, and the predictive gain of the residual model extended by
  the candidate (exact conjugate regression of e on a per-stratum intercept plus the candidate,
  PSIS-LOO against the intercepts alone). This two-stage gain treats the fitted means as known;
  the fitted model's own ELPD (PSIS-LOO of its ``log_likelihood`` group) is the baseline shown.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pandas as pd

from .._domain import SURFACES, TYRE_TYPES
from .._errors import BadInputError
from ..inference.fleet.data import fleet_data_from_table
from ..inference.result import Fit, load_fit
from .fleet import candidates_from_table
from .linear import loo_from_pointwise, psis_loo_pointwise
from .permutation import DEFAULT_PERMUTATIONS
from .ppc import posterior_predictive_check, residual_correlation
from .scan import DEFAULT_ALPHA, ELPD_SE_FACTOR, CriticismResult, criticize_linear

#: Prior variance of the per-stratum intercepts of the residual model (units of its sd^2).
_PRIOR_VAR_INTERCEPT = 100.0


def _as_fit(fit: Fit | str | os.PathLike, kind: str) -> Fit:
    return load_fit(fit, kind=kind) if not isinstance(fit, Fit) else fit


def fleet_row_means(fit: Fit) -> tuple[np.ndarray, np.ndarray]:
    """Per posterior draw and row of a fleet fit: predictive mean and sd. Shapes (draws, rows).

    mean = a[s, t] + b[s, t] * (100 / C_xr,true - 100 / c_xr_ref[t]), the fleet model's line
    (:mod:`tyrebayes.inference.fleet.model`).
    """
    const = fit.data["constant_data"]
    rt = np.asarray(const["row_type"], int)
    rs = np.asarray(const["row_surface"], int)
    tyre = np.asarray(const["row_tyre"], int)
    c_ref = np.asarray(json.loads(fit.data.attrs["c_xr_ref"]), float)
    x_scale = float(fit.data.attrs.get("x_scale", 100.0))
    a, b, sigma = fit.draws("a"), fit.draws("b"), fit.draws("sigma")
    c = fit.draws("c_xr_true")[:, tyre]
    z = x_scale / c - x_scale / c_ref[rt]
    return a[:, rs, rt] + b[:, rs, rt] * z, sigma[:, rs, rt]


def criticize_fleet_fit(
    fit: Fit | str | os.PathLike,
    table: pd.DataFrame,
    *,
    alpha: float = DEFAULT_ALPHA,
    seed: int = 0,
    n_draws: int = 2000,
    n_permutations: int = DEFAULT_PERMUTATIONS,
    report_all: bool = True,
    se_factor: float = ELPD_SE_FACTOR,
) -> CriticismResult:
    """Criticise a fleet fit: posterior predictive checks and a calibrated residual scan.

    Parameters
    ----------
    fit : Fit or path
        A fleet fit (``kind="fleet"``) or its file (:meth:`Fit.save`).
    table : pandas.DataFrame
        The fleet table the fit was made from (same rows, same order); every column other than
        ``tyre_id``, ``tyre_type``, ``c_xr``, ``c_xr_sd``, ``surface`` and the outcome is a
        candidate covariate.
    alpha, seed, n_draws, n_permutations, report_all, se_factor
        As in :func:`tyrebayes.criticism.criticize_table`.

    Returns
    -------
    CriticismResult
        ``baseline``: the fitted model's PSIS-LOO; candidates with effect (outcome units per
        covariate unit, 90 % HDI), permutation p, BH q, ELPD gain of the residual model and its
        SE, found; posterior predictive checks of the fit; notes.

    Raises
    ------
    BadInputError
        Not a fleet fit, or a table that is not the one the fit was made from.

    Examples
    --------
    >>> from tyrebayes.inference.fleet import fit_fleet  # doctest: +SKIP
    >>> from tyrebayes.simulate.fleet import simulate_fleet  # doctest: +SKIP
    >>> table, _ = simulate_fleet(0, 26, effects=("age",))  # doctest: +SKIP
    >>> criticize_fleet_fit(fit_fleet(table), table).found  # doctest: +SKIP
    ['age_years']
    """
    fit = _as_fit(fit, "fleet")
    if fit.kind != "fleet":
        raise BadInputError(f"fit: expected a fleet fit, got a {fit.kind} fit")
    outcome = str(fit.data.attrs["outcome"])
    y = np.asarray(fit.data["observed_data"][outcome], float)
    data = fleet_data_from_table(table, outcome)
    const = fit.data["constant_data"]
    same = (
        data.y.shape == y.shape
        and np.allclose(data.y, y)
        and np.array_equal(data.row_tyre, np.asarray(const["row_tyre"], int))
        and np.array_equal(data.row_surface, np.asarray(const["row_surface"], int))
    )
    if not same:
        raise BadInputError(
            f"table: expected the fleet table the fit was made from ({y.shape[0]} rows of "
            f"{outcome!r} in the same order), got {len(table)} rows that differ"
        )
    mean, sigma = fleet_row_means(fit)
    resid = y - mean.mean(axis=0)
    scale = float(np.std(resid))
    scale = scale if scale > 0 else 1.0
    stratum_key = data.row_surface * 16 + data.row_type
    strata = np.unique(stratum_key, return_inverse=True)[1]
    onehot = np.eye(int(strata.max()) + 1)[strata]
    candidates = candidates_from_table(table.reset_index(drop=True), outcome)
    _, _, results, found, notes = criticize_linear(
        resid / scale,
        onehot,
        np.full(onehot.shape[1], _PRIOR_VAR_INTERCEPT),
        candidates,
        y_scale=scale,
        groups=onehot,
        strata=strata,
        alpha=alpha,
        seed=seed,
        n_draws=n_draws,
        n_permutations=n_permutations,
        report_all=report_all,
        se_factor=se_factor,
    )
    loglik = np.asarray(fit.data["log_likelihood"][outcome], float).reshape(-1, y.shape[0])
    elpd_i, k = psis_loo_pointwise(loglik)
    baseline = loo_from_pointwise(elpd_i, k, 0)
    y_rep = np.asarray(fit.data["posterior_predictive"][outcome], float).reshape(-1, y.shape[0])
    ppc = _fit_ppc(y, y_rep, mean, data, candidates, table)
    notes = [
        f"fitted model: hierarchical fleet fit ({fit.provenance.method}, converged "
        f"{fit.converged}, adequate {fit.adequate}); PSIS-LOO ELPD {baseline.elpd:.2f} "
        f"(SE {baseline.se:.2f}), {baseline.n_k_high} row(s) with Pareto k > 0.7",
        "residual scan: residuals of the fitted model at its posterior mean, permuted within "
        "surface x tyre type; ELPD gain of a residual regression on the candidate (two-stage: "
        "the fitted means taken as known)",
        *notes,
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


def _fit_ppc(y, y_rep, mean, data, candidates, table: pd.DataFrame) -> dict:
    """Posterior predictive checks of the fit: per surface, per type sd, residual correlations."""
    out = {}
    for s in np.unique(data.row_surface):
        rows = data.row_surface == s
        for name, v in posterior_predictive_check(y[rows], y_rep[:, rows]).to_dict().items():
            out[f"{name} [{SURFACES[s]}]"] = v
        for t in np.unique(data.row_type[rows]):
            rt = rows & (data.row_type == t)
            if rt.sum() < 3:
                continue
            t_obs = float(np.std(y[rt]))
            t_rep = np.std(y_rep[:, rt], axis=1)
            out[f"sd [{SURFACES[s]}, {TYRE_TYPES[t]}]"] = {
                "observed": t_obs,
                "p_value": float(np.mean(t_rep >= t_obs)),
            }
    for cand in candidates:
        if cand.covariate_type != "numeric" or not np.all(np.isfinite(cand.columns)):
            continue
        x = cand.columns[:, 0]
        r_obs = residual_correlation(y[None, :] - mean, x)
        r_rep = residual_correlation(y_rep - mean, x)
        out[f"|corr(residual, {cand.name})|"] = {
            "observed": float(np.mean(r_obs)),
            "p_value": float(np.mean(r_rep >= r_obs)),
        }
    return out
