"""Criticism of a fleet table: candidate covariates against the type-pooled regression on 1/C_xr."""

from __future__ import annotations

import numpy as np
import pandas as pd

from .fleet import baseline_design, candidates_from_table, select_rows, type_onehot
from .permutation import DEFAULT_PERMUTATIONS
from .ppc import posterior_predictive_check, residual_correlation
from .scan import DEFAULT_ALPHA, ELPD_SE_FACTOR, CriticismResult, criticize_linear


def criticize_table(
    table: pd.DataFrame,
    outcome: str,
    *,
    surface: str | None = None,
    alpha: float = DEFAULT_ALPHA,
    seed: int = 0,
    n_draws: int = 2000,
    n_permutations: int = DEFAULT_PERMUTATIONS,
    report_all: bool = True,
    se_factor: float = ELPD_SE_FACTOR,
) -> CriticismResult:
    """Criticise the type-pooled regression of ``outcome`` on 1/C_xr with every other column.

    Parameters
    ----------
    table : pandas.DataFrame
        Fleet table: ``tyre_type``, ``c_xr``, the outcome, optional ``tyre_id``, ``c_xr_sd``,
        ``surface``; every other column (numeric or categorical) is a candidate covariate.
    outcome : str
        Outcome column (e.g. ``"mu"``, friction potential on one surface).
    surface : str or None
        Surface to criticise when the table holds several.
    alpha : float
        False-discovery rate of the rule (Benjamini-Hochberg over candidates).
    seed : int
        Seed of the permutations and posterior draws (results are deterministic given it).
    n_draws : int
        Exact posterior draws per model.
    n_permutations : int
        Permutations of the baseline's residuals (within tyre types) behind each p-value.
    report_all : bool
        Fit every candidate's extended model (default). ``False`` fits only those that pass the
        scan (others get NaN ELPD and effect) and skips the predictive checks; the findings are
        the same, large fleets faster.
    se_factor : float
        A finding's ELPD gain must exceed ``se_factor`` standard errors (default 0); it must be
        positive in any case.

    Returns
    -------
    CriticismResult
        Baseline ELPD, candidates sorted by evidence (permutation p-value, BH q-value, ELPD gain
        over the baseline with its SE, the effect's posterior in outcome units per covariate
        unit), ``found`` (the rule of :mod:`tyrebayes.criticism.scan`), posterior predictive
        checks, notes.

    Raises
    ------
    BadInputError
        Bad tables (missing columns, unknown types, non-positive stiffness, too few rows).

    Examples
    --------
    >>> from tyrebayes.simulate.fleet import simulate_fleet
    >>> table, _ = simulate_fleet(0, 26, effects=("age",))
    >>> criticize_table(table, "mu").found
    ['age_years']
    """
    rows = select_rows(table, outcome, surface)
    y, x0, prior0, y_scale, _ = baseline_design(rows, outcome)
    candidates = candidates_from_table(rows, outcome)
    base_loo, base_fit, results, found, notes = criticize_linear(
        y,
        x0,
        prior0,
        candidates,
        y_scale=y_scale,
        groups=type_onehot(rows),
        alpha=alpha,
        seed=seed,
        n_draws=n_draws,
        n_permutations=n_permutations,
        report_all=report_all,
        se_factor=se_factor,
    )
    # Posterior predictive checks of the baseline, including the realised discrepancy
    # |corr(residual, candidate)| for every numeric candidate (the scan seen through the PPC).
    ppc = _fleet_ppc(y, x0, base_fit, candidates, seed) if report_all else {}
    notes = [
        "baseline: conjugate Normal-Inverse-Gamma regression of the outcome on 100/C_xr, "
        "intercept per tyre type, slope partially pooled by type (fixed hyper-variance), "
        "shared residual sd; C_xr taken as exact (criticise a fit file to check the "
        "hierarchical model itself: tyrebayes.criticism.criticize_fleet_fit)",
        *notes,
    ]
    return CriticismResult(
        baseline=base_loo,
        candidates=results,
        found=found,
        ppc=ppc,
        notes=notes,
        alpha=alpha,
        n_permutations=n_permutations,
    )


def _fleet_ppc(y, x0, base_fit, candidates, seed: int) -> dict:
    """Baseline PPC: default statistics and |corr(residual, candidate)| per numeric candidate."""
    rng = np.random.default_rng(seed + 1)
    mu = base_fit.beta @ x0.T
    y_rep = mu + base_fit.sigma[:, None] * rng.standard_normal(mu.shape)
    ppc = posterior_predictive_check(y, y_rep).to_dict()
    for cand in candidates:
        if cand.covariate_type != "numeric" or not np.all(np.isfinite(cand.columns)):
            continue
        xc = cand.columns[:, 0]
        r_obs = residual_correlation(y[None, :] - mu, xc)
        r_rep = residual_correlation(y_rep - mu, xc)
        ppc[f"|corr(residual, {cand.name})|"] = {
            "observed": float(np.mean(r_obs)),
            "p_value": float(np.mean(r_rep >= r_obs)),
        }
    return ppc
