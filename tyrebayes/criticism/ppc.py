"""Posterior predictive checks: test statistics of the data against their replicates."""

from __future__ import annotations

from collections.abc import Callable, Mapping

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


def posterior_predictive_check(
    y: Float[np.ndarray, " n"],
    y_rep: Float[np.ndarray, "s n"],
    statistics: Mapping[str, Callable[[np.ndarray], np.ndarray]] | None = None,
) -> dict[str, dict[str, float]]:
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
    dict
        ``{name: {"observed": T(y), "p_value": p}}``. A p-value near 0 or 1 (outside
        [0.025, 0.975]) says the model does not reproduce that feature of the data.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> out = posterior_predictive_check(rng.normal(size=50), rng.normal(size=(400, 50)))
    >>> 0.0 < out["sd"]["p_value"] < 1.0
    True
    """
    stats = DEFAULT_STATISTICS if statistics is None else statistics
    out = {}
    for name, fn in stats.items():
        t_obs = float(fn(y))
        t_rep = np.asarray(fn(y_rep), dtype=float)
        out[name] = {"observed": t_obs, "p_value": float(np.mean(t_rep >= t_obs))}
    return out


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
