"""The discovery rule shared by fleet-table, fitted-model and stream criticism.

A candidate covariate is a *finding* when three things hold, in this order:

1. **Calibrated scan.** The share of the baseline's residual sum of squares the candidate
   explains is compared with its permutation distribution (Freedman-Lane permutations of the
   baseline's residuals within strata, :mod:`.permutation`): a p-value calibrated without
   assuming Gaussian noise.
2. **False-discovery-rate control.** Benjamini-Hochberg over all candidates: the candidate's
   q-value must be at most ``alpha`` (default 0.05), so that on average about 5 % of the
   reported findings are false at most (on a table where nothing is there: about 5 % of tables
   report anything). "About": the Freedman-Lane permutation p-values are calibrated
   approximately, not exactly, when the baseline has many coefficients for its rows.
3. **Predictive confirmation.** The extended model (baseline + the candidate) must predict
   better than the baseline: its PSIS-LOO ELPD gain must be positive (and exceed ``se_factor``
   standard errors, default 0). A finding with a negative gain cannot happen.

Findings are then confirmed one after another, strongest first: a later one must also pass the
permutation scan (at ``alpha``) and have a positive ELPD gain *given* the earlier findings, so a
covariate that only correlates with a finding drops out. Every candidate is reported with its
effect in natural units (posterior mean, sd, 90 % HDI from the extended model), its p- and
q-value, the ELPD gain and SE, the Pareto-k diagnostics and the reason for the decision.

Measured error rates and power: ``benchmarks/discovery.py`` (``benchmarks/results/discovery.json``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from jaxtyping import Float, Int
from scipy import stats

from ..inference.summary import summarize
from .linear import LinearFit, LooResult, difference, fit_and_loo, loo_from_pointwise, ols_rss
from .multiple_testing import DEFAULT_ALPHA as DEFAULT_ALPHA
from .multiple_testing import benjamini_hochberg as benjamini_hochberg
from .multiple_testing import holm as holm
from .permutation import (
    DEFAULT_PERMUTATIONS,
    permutation_pvalue,
    permutation_pvalues,
    stratified_permutations,
    unit_means,
)
from .results import Candidate as Candidate
from .results import CandidateResult as CandidateResult
from .results import CriticismResult as CriticismResult

#: A finding's ELPD gain must exceed this many standard errors (and be positive in any case).
ELPD_SE_FACTOR = 0.0
#: Prior variance (units of sigma^2, standardised covariate) of a candidate's coefficient.
CANDIDATE_PRIOR_VAR = 25.0
#: Prior variance of the per-group deviations of a numeric candidate's coefficient (partial
#: pooling by tyre type: a type may feel the effect more or less, e.g. when its friction saturates).
CANDIDATE_DEVIATION_PRIOR_VAR = 0.25


def partial_f_test(
    x0: Float[np.ndarray, "n p"], extra: Float[np.ndarray, "n q"], y: Float[np.ndarray, " n"]
) -> tuple[float, float]:
    """Partial F test of adding ``extra`` to ``x0`` (the exact likelihood-ratio test).

    Returns
    -------
    p_value : float
        1 when the extended model has no residual degrees of freedom or adds no rank.
    explained : float
        Share of the baseline residual sum of squares the extra columns explain (partial R^2).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> x = rng.normal(size=50)
    >>> y = 0.5 * x + rng.normal(size=50)
    >>> p, r2 = partial_f_test(np.ones((50, 1)), x[:, None], y)
    >>> bool(p < 0.01)
    True
    """
    rss0, rank0 = ols_rss(x0, y)
    rss1, rank1 = ols_rss(np.column_stack([x0, extra]), y)
    q = rank1 - rank0
    df2 = y.shape[0] - rank1
    if q <= 0 or df2 <= 0 or rss0 <= 0:
        return 1.0, 0.0
    f = ((rss0 - rss1) / q) / max(rss1 / df2, 1e-300)
    return float(stats.f.sf(f, q, df2)), float((rss0 - rss1) / rss0)


def _loglik_scan(
    elpd_units: Float[np.ndarray, " u"], cand: Candidate, units: Int[np.ndarray, " n"] | None
) -> float:
    """p-value of the per-unit LOO log-likelihood regressed on the candidate (mean per row)."""
    if units is None:
        values, elpd = cand.columns, elpd_units
    else:
        labels, first = np.unique(units, return_index=True)
        values = cand.columns[first]
        elpd = elpd_units / np.bincount(units).astype(float)[labels]
    ok = np.all(np.isfinite(values), axis=1)
    return partial_f_test(np.ones((int(ok.sum()), 1)), values[ok], elpd[ok])[0]


def _effect(
    fit: LinearFit, p0: int, cand: Candidate, y_scale: float, group_share: np.ndarray | None
) -> tuple[dict, str | None]:
    """Posterior summary of the candidate's coefficient in natural units (strongest level).

    With per-group deviations (``group_share`` given, numeric candidates) the effect is the
    fleet-average coefficient, pooled + sum_g share_g * deviation_g: it is what the data
    identify (the pooled coefficient alone is only separated from the deviations by the prior).
    """
    q = cand.columns.shape[1]
    coef = fit.beta[:, p0 : p0 + q]
    if group_share is not None and fit.beta.shape[1] == p0 + q + group_share.shape[0]:
        coef = coef + fit.beta[:, p0 + q :] @ group_share[:, None]
    draws = coef * y_scale / cand.natural_scale[None, :]
    z = np.abs(draws.mean(axis=0)) / np.maximum(draws.std(axis=0), 1e-300)
    j = int(np.argmax(z))
    level = cand.labels[j] if cand.covariate_type == "categorical" else None
    return summarize(draws[:, j]).to_dict(), level


def criticize_linear(
    y: Float[np.ndarray, " n"],
    x0: Float[np.ndarray, "n p"],
    prior0: Float[np.ndarray, " p"],
    candidates: Sequence[Candidate],
    *,
    y_scale: float,
    units: Int[np.ndarray, " n"] | None = None,
    groups: Float[np.ndarray, "n g"] | None = None,
    strata: Int[np.ndarray, " n"] | None = None,
    alpha: float = DEFAULT_ALPHA,
    seed: int = 0,
    n_draws: int = 2000,
    n_permutations: int = DEFAULT_PERMUTATIONS,
    report_all: bool = True,
    se_factor: float = ELPD_SE_FACTOR,
) -> tuple[LooResult, LinearFit, list[CandidateResult], list[str], list[str]]:
    """Scan, control the false-discovery rate, confirm and summarise candidates (module docstring).

    Parameters
    ----------
    y, x0, prior0
        Standardised outcome, baseline design and the prior variances of its coefficients.
    candidates : sequence of Candidate
    y_scale : float
        Converts the ELPD and the effects back to natural units.
    units : ndarray of int or None
        Rows left out together (stream segments, blocks of windows); the scan then works on
        unit means (degrees of freedom of units, not of autocorrelated rows).
    groups : ndarray (n, g) or None
        One-hot groups (tyre types): a numeric candidate's coefficient may deviate per group
        (partially pooled; the reported effect is the fleet-average coefficient).
    strata : ndarray of int or None
        Rows exchangeable under the null (permutations stay within a stratum); default the
        groups, else all rows.
    alpha : float
        False-discovery rate (Benjamini-Hochberg over candidates).
    seed : int
        Seed of the permutations and the posterior draws.
    n_draws, n_permutations : int
        Exact posterior draws per model; permutations per scan.
    report_all : bool
        Fit every candidate's extended model (default). ``False`` fits only candidates whose
        q-value passes (the others get NaN ELPD and effect; the decision is the same).
    se_factor : float
        A finding's ELPD gain must exceed ``se_factor`` SE, and 0 in any case.

    Returns
    -------
    tuple
        Baseline LOO (natural units), baseline fit, candidate results sorted by evidence, the
        findings, and notes.
    """
    rng = np.random.default_rng(seed)
    n = y.shape[0]
    if strata is None:
        strata = np.zeros(n, int) if groups is None else np.argmax(groups, axis=1)
    run = _LinearScan(y, units, groups, strata, rng, n_draws, n_permutations, y_scale)
    notes: list[str] = []

    all_rows = np.arange(n)
    base_fit = run.fit(x0, prior0, all_rows)
    base_loo = run.to_natural(base_fit.loo, all_rows)
    if base_loo.n_k_high:
        notes.append(
            f"baseline: {base_loo.n_k_high} unit(s) with Pareto k > 0.7 "
            f"(max {base_loo.k_max:.2f}); replaced by exact leave-one-out densities"
        )
    # 1-2. Calibrated scan of every candidate against the baseline, BH over candidates.
    scans, p_values, q_values, p_ll = _scan_candidates(run, x0, candidates, base_loo, alpha, notes)
    # 3. Extended models and their ELPD gain over the baseline on the same rows.
    marginal = _marginal_gains(
        run, x0, prior0, candidates, q_values, base_fit, alpha, report_all, notes
    )

    def gain_ok(gain: float, se: float) -> bool:
        return bool(gain > 0.0 and gain > se_factor * se)

    reasons: dict[str, str] = {}
    passing = []
    for i, (cand, q) in enumerate(zip(candidates, q_values, strict=True)):
        if q > alpha:
            reasons[cand.name] = f"scan: q {q:.2g} > {alpha:g}"
            continue
        gain, se = marginal[cand.name][2:]
        if not gain_ok(gain, se):
            reasons[cand.name] = (
                f"scan passes (q {q:.2g}) but the extended model does not predict better "
                f"(ELPD gain {gain:.2f}, SE {se:.2f})"
            )
            continue
        passing.append(i)
    passing.sort(key=lambda i: (p_values[i], -marginal[candidates[i].name][2]))

    chosen, chosen_effect = _confirm(
        run, x0, prior0, candidates, passing, q_values, marginal, alpha, gain_ok, reasons, notes
    )
    results = _candidate_results(
        run, x0, candidates, scans, q_values, p_ll, marginal, chosen_effect, reasons
    )
    order = {c.name: i for i, c in enumerate(chosen)}
    results.sort(
        key=lambda r: (
            order.get(r.covariate, len(order)),
            r.p_value,
            -(r.elpd_gain / max(r.se, 1e-12)) if np.isfinite(r.elpd_gain) else np.inf,
        )
    )
    return base_loo, base_fit, results, [c.name for c in chosen], notes


class _LinearScan:
    """What the steps of one :func:`criticize_linear` run share: its data, random numbers and
    permutations (made once per set of rows and reused, in the order the steps ask for them)."""

    def __init__(self, y, units, groups, strata, rng, n_draws, n_permutations, y_scale):
        self.y, self.units, self.groups, self.strata = y, units, groups, strata
        self.rng, self.n_draws, self.n_permutations = rng, n_draws, n_permutations
        self.log_scale = np.log(y_scale)
        self.y_scale = y_scale
        self.n = y.shape[0]
        self.perm_cache: dict[tuple, np.ndarray] = {}

    def permutations_for(self, key: tuple, labels: np.ndarray) -> np.ndarray:
        if key not in self.perm_cache:
            self.perm_cache[key] = stratified_permutations(labels, self.n_permutations, self.rng)
        return self.perm_cache[key]

    def scan(self, x, cols, rows) -> tuple[float, float]:
        y, units = self.y, self.units
        extra = cols[rows]
        if units is None:
            perms = self.permutations_for(
                ("rows", rows.shape[0], rows.tobytes()), self.strata[rows]
            )
            return permutation_pvalue(y[rows], x[rows], extra, perms)
        # Unit level: the current model's residuals averaged per unit against the unit means.
        coef, *_ = np.linalg.lstsq(x[rows], y[rows], rcond=None)
        resid = y[rows] - x[rows] @ coef
        u = np.unique(units[rows], return_inverse=True)[1]
        r_u = unit_means(resid[:, None], u)[:, 0]
        x_u = unit_means(extra, u)
        perms = self.permutations_for(
            ("units", r_u.shape[0], rows.tobytes()), np.zeros(r_u.shape[0], int)
        )
        return permutation_pvalue(r_u, np.ones((r_u.shape[0], 1)), x_u, perms)

    def fit(self, x, prior, rows):
        units = self.units
        u = None if units is None else np.unique(units[rows], return_inverse=True)[1]
        return fit_and_loo(x[rows], self.y[rows], prior, self.rng, n_draws=self.n_draws, units=u)

    def to_natural(self, loo: LooResult, rows) -> LooResult:
        # Jacobian of the standardisation: log p(y) = log p(y_std) - log(scale), per row.
        units = self.units
        rows_per_unit = (
            np.ones(loo.pointwise.shape[0])
            if units is None
            else np.bincount(np.unique(units[rows], return_inverse=True)[1]).astype(float)
        )
        pw = loo.pointwise - rows_per_unit * self.log_scale
        return loo_from_pointwise(pw, loo.pareto_k, loo.n_exact)

    def extend(self, x, prior, cand):
        groups = self.groups
        x1 = np.column_stack([x, np.nan_to_num(cand.columns)])
        prior1 = np.concatenate([prior, np.full(cand.columns.shape[1], CANDIDATE_PRIOR_VAR)])
        if groups is not None and cand.covariate_type == "numeric" and groups.shape[1] > 1:
            x1 = np.column_stack([x1, groups * np.nan_to_num(cand.columns)])
            prior1 = np.concatenate(
                [prior1, np.full(groups.shape[1], CANDIDATE_DEVIATION_PRIOR_VAR)]
            )
        return x1, prior1

    def share(self, rows):
        return None if self.groups is None else self.groups[rows].mean(axis=0)

    def finite_rows(self, *cands):
        ok = np.ones(self.n, dtype=bool)
        for c in cands:
            ok &= np.all(np.isfinite(c.columns), axis=1)
        return np.flatnonzero(ok)


def _scan_candidates(run: _LinearScan, x0, candidates, base_loo, alpha, notes):
    """Steps 1-2: each candidate's permutation scan against the baseline, BH over candidates.

    Returns ``(scans, p_values, q_values, p_loglik)``; notes where the baseline's pointwise
    log-likelihood changes with a candidate.
    """
    n, units = run.n, run.units
    all_rows = np.arange(n)
    # Candidates without missing values share one batch of permutations.
    complete = [np.all(np.isfinite(c.columns)) for c in candidates]
    if units is None and any(complete):
        perms = run.permutations_for(("rows", n, all_rows.tobytes()), run.strata)
        batch = iter(
            permutation_pvalues(
                run.y,
                x0,
                [c.columns for c, ok in zip(candidates, complete, strict=True) if ok],
                perms,
            )
        )
    scans = [
        next(batch) if ok and units is None else run.scan(x0, cand.columns, run.finite_rows(cand))
        for cand, ok in zip(candidates, complete, strict=True)
    ]
    p_values = np.array([s[0] for s in scans])
    q_values = benjamini_hochberg(p_values) if scans else np.zeros(0)
    p_ll = np.array([_loglik_scan(base_loo.pointwise, cand, units) for cand in candidates])
    for cand, p_adj in zip(candidates, benjamini_hochberg(p_ll) if p_ll.size else [], strict=True):
        if p_adj <= alpha:
            notes.append(
                f"{cand.name}: the baseline's pointwise log-likelihood changes with it (BH q "
                f"{p_adj:.2g}) — the fit is worse in part of its range (a noise level or outliers "
                "there), which a mean-shift extension may not capture"
            )
    return scans, p_values, q_values, p_ll


def _marginal_gains(
    run: _LinearScan, x0, prior0, candidates, q_values, base_fit, alpha, report_all, notes
) -> dict:
    """Step 3: each candidate's extended model and its ELPD gain over the baseline on the same
    rows: ``name -> (baseline LOO, extended fit, gain, SE)``."""
    marginal = {}
    for cand, q in zip(candidates, q_values, strict=True):
        if not report_all and q > alpha:
            continue  # cannot be a finding; its ELPD is only needed for the report
        rows = run.finite_rows(cand)
        if rows.shape[0] < run.n:
            notes.append(
                f"{cand.name}: {run.n - rows.shape[0]} row(s) without a value were left out of "
                "its comparison"
            )
            base = run.fit(x0, prior0, rows).loo
        else:
            base = base_fit.loo
        ext_fit = run.fit(*run.extend(x0, prior0, cand), rows)
        marginal[cand.name] = (base, ext_fit) + difference(base, ext_fit.loo)
    return marginal


def _confirm(
    run: _LinearScan,
    x0,
    prior0,
    candidates,
    passing,
    q_values,
    marginal,
    alpha,
    gain_ok,
    reasons,
    notes,
):
    """Confirmation in order of evidence: later findings must hold given the earlier ones.

    Returns the findings and their effects ``name -> (effect, level)``; writes each
    candidate's reason.
    """
    chosen: list[Candidate] = []
    chosen_effect: dict[str, tuple[dict, str | None]] = {}
    x_cur, prior_cur = x0, prior0
    for i in passing:
        cand = candidates[i]
        rows = run.finite_rows(cand, *chosen)
        x_new, prior_new = run.extend(x_cur, prior_cur, cand)
        if chosen:
            p_cond = run.scan(x_cur, cand.columns, rows)[0]
            cur = run.fit(x_cur, prior_cur, rows).loo
            new_fit = run.fit(x_new, prior_new, rows)
            gain, se = difference(cur, new_fit.loo)
            given = ", ".join(c.name for c in chosen)
            if p_cond > alpha or not gain_ok(gain, se):
                reasons[cand.name] = (
                    f"passes alone (q {q_values[i]:.2g}) but not given {given}: permutation p "
                    f"{p_cond:.2g}, ELPD gain {gain:.2f} (SE {se:.2f})"
                )
                continue
            notes.append(
                f"{cand.name}: given {given}, permutation p {p_cond:.2g}, ELPD gain {gain:.2f} "
                f"(SE {se:.2f})"
            )
        else:
            new_fit = marginal[cand.name][1]
        reasons[cand.name] = f"q {q_values[i]:.2g} <= {alpha:g} and ELPD gain > 0" + (
            f" (also given {', '.join(c.name for c in chosen)})" if chosen else ""
        )
        chosen_effect[cand.name] = _effect(
            new_fit, x_cur.shape[1], cand, run.y_scale, run.share(rows)
        )
        chosen.append(cand)
        x_cur, prior_cur = x_new, prior_new
    return chosen, chosen_effect


def _candidate_results(
    run: _LinearScan, x0, candidates, scans, q_values, p_ll, marginal, chosen_effect, reasons
) -> list[CandidateResult]:
    """Every candidate's :class:`CandidateResult`, in the order given."""
    results = []
    nan = float("nan")
    for cand, (p, explained), q, pl in zip(candidates, scans, q_values, p_ll, strict=True):
        found = cand.name in chosen_effect
        if cand.name not in marginal:
            effect, level = {"mean": nan, "sd": nan, "hdi_90": [nan, nan]}, None
            gain = se = k_max = nan
            k_high = n_units = 0
        else:
            base, ext_fit, gain, se = marginal[cand.name]
            if found:
                effect, level = chosen_effect[cand.name]
            else:
                rows = run.finite_rows(cand)
                effect, level = _effect(ext_fit, x0.shape[1], cand, run.y_scale, run.share(rows))
            k_max = max(ext_fit.loo.k_max, base.k_max)
            k_high = ext_fit.loo.n_k_high
            n_units = int(ext_fit.loo.pointwise.shape[0])
        results.append(
            CandidateResult(
                covariate=cand.name,
                covariate_type=cand.covariate_type,
                level=level,
                effect=effect,
                p_value=float(p),
                q_value=float(q),
                misfit_explained=float(explained),
                elpd_gain=float(gain),
                se=float(se),
                pareto_k_max=float(k_max),
                n_k_high=int(k_high),
                n_units=n_units,
                found=found,
                reason=reasons[cand.name],
                p_loglik=float(pl),
            )
        )
    return results
