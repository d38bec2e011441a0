"""The thesis' baseline: one least-squares line of friction against inverse stiffness.

Thesis Sec. 6.1 fits y = beta_0 + beta_1 x with x = 1 / C_xr to the mean friction potential of
each tyre set (26 winter tests, R^2 ~ 0.8), ignoring tyre type and the error in C_xr. This module
reproduces it, with the classical predictive t-interval for a new set, so that the hierarchical
fleet model can be compared with it on the same data.
"""

from __future__ import annotations

import math

import equinox as eqx
import numpy as np
from scipy import stats

from .._errors import BadInputError


class OLSFit(eqx.Module):
    """Least-squares line mu = intercept + slope / C_xr (thesis Sec. 6.1).

    Fields: ``intercept`` [mu], ``slope`` [mu * C_xr], ``resid_sd`` (unbiased residual sd, n - 2
    degrees of freedom), ``n_obs``, ``xtx_inv`` ((X^T X)^-1, 2 x 2, for predictive intervals),
    ``r2`` (coefficient of determination, as in the thesis).
    """

    intercept: float
    slope: float
    resid_sd: float
    n_obs: int
    xtx_inv: np.ndarray
    r2: float

    def __check_init__(self):
        if self.n_obs < 3:
            raise ValueError(
                f"n_obs: expected >= 3 for a line with a residual sd, got {self.n_obs}"
            )
        if not self.resid_sd >= 0:
            raise ValueError(f"resid_sd: expected >= 0, got {self.resid_sd}")


def _design(c_xr) -> np.ndarray:
    c = np.asarray(c_xr, float)
    return np.stack([np.ones_like(c), 1.0 / c], axis=-1)


def fit_ols(c_xr, mu) -> OLSFit:
    """Fit mu = b0 + b1 / C_xr by ordinary least squares (thesis Sec. 6.1).

    Parameters
    ----------
    c_xr : array_like, shape (n,)
        Compensated stiffness of each tyre set (dimensionless, > 0).
    mu : array_like, shape (n,)
        Friction potential of each set (dimensionless).

    Returns
    -------
    OLSFit

    Examples
    --------
    >>> fit = fit_ols([25.0, 30.0, 50.0, 60.0], [0.5, 0.45, 0.2, 0.18])
    >>> fit.slope > 0
    True
    """
    c = np.asarray(c_xr, float).ravel()
    y = np.asarray(mu, float).ravel()
    if c.shape != y.shape:
        raise BadInputError(f"OLS: expected c_xr and mu of equal length, got {c.size} and {y.size}")
    if not (np.all(np.isfinite(c)) and np.all(c > 0) and np.all(np.isfinite(y))):
        raise BadInputError("OLS: expected positive finite c_xr and finite mu, got other values")
    if c.size < 3:
        raise BadInputError(f"OLS: expected at least 3 tyre sets, got {c.size}")
    X = _design(c)
    xtx_inv = np.linalg.inv(X.T @ X)
    beta = xtx_inv @ X.T @ y
    resid = y - X @ beta
    dof = c.size - 2
    ss_tot = float(np.sum((y - y.mean()) ** 2))
    return OLSFit(
        intercept=float(beta[0]),
        slope=float(beta[1]),
        resid_sd=float(math.sqrt(np.sum(resid**2) / dof)),
        n_obs=int(c.size),
        xtx_inv=xtx_inv,
        r2=float(1.0 - np.sum(resid**2) / ss_tot) if ss_tot > 0 else float("nan"),
    )


def ols_predictive(fit: OLSFit, c_xr) -> tuple[np.ndarray, np.ndarray, int]:
    """Predictive Student-t for a new set: (location, scale, degrees of freedom).

    scale = s * sqrt(1 + x0^T (X^T X)^-1 x0), dof = n - 2 (classical prediction interval).
    """
    x0 = _design(c_xr)
    loc = x0 @ np.array([fit.intercept, fit.slope])
    h = np.einsum("...i,ij,...j->...", x0, fit.xtx_inv, x0)
    return loc, fit.resid_sd * np.sqrt(1.0 + h), fit.n_obs - 2


def ols_interval(
    fit: OLSFit, c_xr, level: float = 0.9
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Predictive mean and central ``level`` t-interval of mu for new sets: (mean, lo, hi)."""
    loc, scale, dof = ols_predictive(fit, c_xr)
    q = stats.t.ppf(0.5 + level / 2.0, dof)
    return loc, loc - q * scale, loc + q * scale


def ols_logpdf(fit: OLSFit, c_xr, mu) -> np.ndarray:
    """Log predictive density of observed ``mu`` at ``c_xr`` under the fitted line."""
    loc, scale, dof = ols_predictive(fit, c_xr)
    return stats.t.logpdf(np.asarray(mu, float), dof, loc=loc, scale=scale)


def ols_loo_logpdf(c_xr, mu) -> np.ndarray:
    """Exact leave-one-out log predictive density of each set (n refits of the line)."""
    c = np.asarray(c_xr, float).ravel()
    y = np.asarray(mu, float).ravel()
    out = np.empty(c.size)
    for i in range(c.size):
        keep = np.arange(c.size) != i
        out[i] = ols_logpdf(fit_ols(c[keep], y[keep]), c[i : i + 1], y[i : i + 1])[0]
    return out
