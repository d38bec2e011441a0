"""What criticism takes and gives: a candidate covariate, the evidence about it, and the
outcome of a criticism run (:class:`CriticismResult`, the CLI's JSON via ``to_json``).

Re-exported by :mod:`tyrebayes.criticism.scan` and :mod:`tyrebayes.criticism`.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np

from .linear import LooResult
from .multiple_testing import DEFAULT_ALPHA
from .permutation import DEFAULT_PERMUTATIONS


class Candidate(eqx.Module):
    """One candidate covariate, encoded as standardised design columns.

    Attributes
    ----------
    name : str
        Column name in the user's data.
    covariate_type : str
        ``"numeric"`` or ``"categorical"``: how the covariate is encoded in ``columns``.
    columns : ndarray (n, q)
        Standardised columns (NaN marks a missing value; such rows are left out of this
        candidate's comparison, and of its baseline).
    natural_scale : ndarray (q,)
        Divide a standardised coefficient by this (and multiply by the outcome scale) to obtain the
        effect in natural units (outcome per unit of the covariate, or per level contrast).
    labels : tuple of str
        One label per column (the level for categorical candidates).
    """

    name: str
    covariate_type: str
    columns: np.ndarray
    natural_scale: np.ndarray
    labels: tuple[str, ...]


class CandidateResult(eqx.Module):
    """Evidence about one candidate covariate.

    Attributes
    ----------
    covariate, covariate_type : str
        Column name; ``"numeric"`` or ``"categorical"``.
    level : str or None
        For categorical candidates the level contrast whose effect is reported (the strongest).
    effect : dict
        Posterior of the candidate's coefficient in the extended model, outcome units per unit of
        the covariate: ``{"mean", "sd", "hdi_90"}`` (90 % highest-density interval).
    p_value : float
        Permutation p-value of the scan (calibrated; smallest 1 / (B + 1)).
    q_value : float
        Benjamini-Hochberg adjusted p-value over all candidates.
    misfit_explained : float
        Share of the baseline's residual sum of squares the candidate explains [-].
    elpd_gain, se : float
        PSIS-LOO ELPD of the extended model minus the baseline's, and the SE of that paired
        difference (NaN when the extended model was not fitted: ``report_all=False`` and the
        scan failed).
    pareto_k_max : float
        Largest Pareto k of the two models (units above 0.7 use exact leave-one-out densities).
    n_k_high, n_units : int
        Units with k > 0.7 in the extended model; units in the comparison.
    found : bool
        Whether the candidate is a finding (module docstring).
    reason : str
        Why it is, or is not, a finding.
    p_loglik : float
        Scan of the baseline's pointwise LOO log-likelihood against the candidate (where the
        model fits worse: a noise level, outliers); descriptive, not part of the decision.

    Examples
    --------
    What :func:`~tyrebayes.criticize_table` reports for each candidate (here made by hand):

    >>> effect = {"mean": -0.036, "sd": 0.004, "hdi_90": [-0.043, -0.029]}
    >>> age = CandidateResult(
    ...     "age_years", "numeric", None, effect, p_value=0.005, q_value=0.03,
    ...     misfit_explained=0.4, elpd_gain=19.2, se=4.6, pareto_k_max=0.8, n_k_high=1,
    ...     n_units=26, found=True, reason="q 0.03 <= 0.05 and ELPD gain > 0", p_loglik=0.5,
    ... )
    >>> age.to_json()["found"], age.to_json()["effect"]["mean"]
    (True, -0.036)
    """

    covariate: str
    covariate_type: str
    level: str | None
    effect: dict
    p_value: float
    q_value: float
    misfit_explained: float
    elpd_gain: float
    se: float
    pareto_k_max: float
    n_k_high: int
    n_units: int
    found: bool
    reason: str
    p_loglik: float

    def to_json(self) -> dict:
        """The CLI contract: covariate, effect, p- and q-value, ELPD gain and SE, found."""
        return {
            "covariate": self.covariate,
            "level": self.level,
            "effect": self.effect,
            "p_value": self.p_value,
            "q_value": self.q_value,
            "elpd_gain": self.elpd_gain,
            "se": self.se,
            "found": self.found,
            "reason": self.reason,
        }


class CriticismResult(eqx.Module):
    """Outcome of a criticism run.

    Attributes
    ----------
    baseline : LooResult
        PSIS-LOO of the baseline model on all units.
    candidates : list of CandidateResult
        Sorted by evidence (findings first in the order confirmed, then by p-value).
    found : list of str
        Covariates judged real.
    ppc : dict
        Posterior predictive checks (statistic -> observed value, p-value).
    notes : list of str
        Assumptions and diagnostics worth telling the user (Pareto k, dropped rows, ...).
    alpha : float
        False-discovery rate of the rule.
    n_permutations : int
        Permutations behind every scan p-value.

    Examples
    --------
    What the criticism functions return (here made by hand, without candidates):

    >>> from tyrebayes.criticism.linear import loo_from_pointwise
    >>> baseline = loo_from_pointwise(np.array([-1.0, -0.5, -0.8]), np.zeros(3), 0)
    >>> result = CriticismResult(baseline, candidates=[], found=[], ppc={}, notes=[])
    >>> result.to_json()["baseline"]["elpd"], result.to_json()["rule"]["n_permutations"]
    (-2.3, 999)
    """

    baseline: LooResult
    candidates: list
    found: list
    ppc: dict
    notes: list
    alpha: float = DEFAULT_ALPHA
    n_permutations: int = DEFAULT_PERMUTATIONS

    def to_json(self) -> dict:
        """``{"baseline": {"elpd", "se"}, "candidates", "found", "rule", "ppc", "notes"}``."""
        return {
            "baseline": {"elpd": self.baseline.elpd, "se": self.baseline.se},
            "candidates": [c.to_json() for c in self.candidates],
            "found": list(self.found),
            "rule": {
                "false_discovery_rate": self.alpha,
                "n_permutations": self.n_permutations,
                "confirmation": "PSIS-LOO ELPD gain of the extended model > 0",
            },
            "ppc": self.ppc,
            "notes": list(self.notes),
        }
