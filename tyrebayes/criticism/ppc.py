"""Posterior predictive checks: test statistics of the data against their replicates."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from jaxtyping import Float


def _skew(x: np.ndarray) -> np.ndarray | np.floating:
    d = x - x.mean(axis=-1, keepdims=True)
    return (d**3).mean(axis=-1) / np.maximum((d**2).mean(axis=-1), 1e-300) ** 1.5


#: Default test statistics T(y) of :func:`posterior_predictive_check` (vectorised over draws).
DEFAULT_STATISTICS: Mapping[str, Callable[[np.ndarray], np.ndarray]] = {
    "mean": lambda y: y.mean(axis=-1),
    "sd": lambda y: y.std(axis=-1),
    "min": lambda y: y.min(axis=-1),
    "max": lambda y: y.max(axis=-1),
    "skewness": _skew,
}


@dataclass(frozen=True)
class StatisticCheck:
    """One test statistic T of a posterior predictive check.

    Attributes
    ----------
    observed : float
        T(y) of the observed data.
    p_value : float
        P(T(y_rep) >= T(y) | y) over the replicates [-]; near 0 or 1 (outside [0.025, 0.975])
        the model does not reproduce that feature of the data.

    Examples
    --------
    >>> StatisticCheck(observed=1.5, p_value=0.25).to_dict()
    {'observed': 1.5, 'p_value': 0.25}
    """

    observed: float
    p_value: float

    def to_dict(self) -> dict[str, float]:
        """``{"observed", "p_value"}``, as the criticism JSON stores each statistic."""
        return {"observed": self.observed, "p_value": self.p_value}


@dataclass(frozen=True)
class PredictiveChecks:
    """The checks of :func:`posterior_predictive_check`, by statistic name in the order run.

    Attributes
    ----------
    checks : tuple of (str, StatisticCheck)
        Each statistic's name and check.

    Examples
    --------
    >>> checks = PredictiveChecks((("sd", StatisticCheck(1.0, 0.5)),))
    >>> checks["sd"].p_value, checks.names
    (0.5, ('sd',))
    >>> checks.to_dict()
    {'sd': {'observed': 1.0, 'p_value': 0.5}}
    """

    checks: tuple[tuple[str, StatisticCheck], ...]

    @property
    def names(self) -> tuple[str, ...]:
        """The statistics' names, in the order run."""
        return tuple(name for name, _ in self.checks)

    def __getitem__(self, name: str) -> StatisticCheck:
        for key, check in self.checks:
            if key == name:
                return check
        raise KeyError(f"predictive check: expected one of {list(self.names)}, got {name!r}")

    def to_dict(self) -> dict[str, dict[str, float]]:
        """``{name: {"observed", "p_value"}}``: what :class:`CriticismResult` and the JSON keep."""
        return {name: check.to_dict() for name, check in self.checks}


def posterior_predictive_check(
    y: Float[np.ndarray, " n"],
    y_rep: Float[np.ndarray, "s n"],
    statistics: Mapping[str, Callable[[np.ndarray], np.ndarray]] | None = None,
) -> PredictiveChecks:
    """Posterior predictive p-values p = P(T(y_rep) >= T(y) | y) of test statistics.

    Parameters
    ----------
    y : ndarray (n,)
        Observed data.
    y_rep : ndarray (draws, n)
        Replicated data, one row per posterior draw.
    statistics : mapping name -> function or None
        Functions T taking an array (..., n) and reducing the last axis; default
        :data:`DEFAULT_STATISTICS` (mean, sd, min, max, skewness).

    Returns
    -------
    PredictiveChecks
        T(y) and p per statistic (``to_dict()``: ``{name: {"observed": T(y), "p_value": p}}``).
        A p-value near 0 or 1 (outside [0.025, 0.975]) says the model does not reproduce that
        feature of the data.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> out = posterior_predictive_check(rng.normal(size=50), rng.normal(size=(400, 50)))
    >>> 0.0 < out["sd"].p_value < 1.0
    True
    >>> out.names
    ('mean', 'sd', 'min', 'max', 'skewness')
    """
    stats = DEFAULT_STATISTICS if statistics is None else statistics
    checks = []
    for name, fn in stats.items():
        t_obs = float(fn(y))
        t_rep = np.asarray(fn(y_rep), dtype=float)
        checks.append((name, StatisticCheck(t_obs, float(np.mean(t_rep >= t_obs)))))
    return PredictiveChecks(tuple(checks))


def residual_correlation(
    resid: Float[np.ndarray, "*draws n"], x: Float[np.ndarray, " n"]
) -> Float[np.ndarray, "*draws"]:
    """|corr(residual, x)| of each row of ``resid``: the check statistic of a candidate covariate.

    A model that missed an effect of ``x`` leaves residuals correlated with it, more than its own
    replicated residuals are (the p-value of the predictive check).
    """
    r = resid - resid.mean(axis=-1, keepdims=True)
    xc = x - x.mean()
    denom = np.sqrt((r**2).sum(axis=-1) * (xc @ xc))
    return np.abs(r @ xc) / np.maximum(denom, 1e-300)
