"""Exact conjugate Bayesian linear regression (Normal-Inverse-Gamma) and PSIS-LOO helpers.

The criticism baselines are Gaussian linear models, so their posterior is available in closed form:

    sigma^2 ~ InvGamma(a0, b0),   beta | sigma^2 ~ Normal(0, sigma^2 diag(v0)),
    y | beta, sigma^2 ~ Normal(X beta, sigma^2 I).

The posterior is again Normal-Inverse-Gamma; we draw from it exactly (independent draws, so the
relative efficiency of PSIS is 1), evaluate the pointwise log-likelihood per draw and estimate the
leave-one-out predictive density with Pareto-smoothed importance sampling (:func:`arviz.psislw`,
the routine :func:`arviz.loo` uses). Because the model is conjugate, the exact leave-one-out
predictive (a Student-t) is also available; it replaces PSIS for observations whose Pareto k
exceeds the reliability threshold (the exact analogue of arviz's ``reloo``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from arviz_stats.base.array import array_stats
from jaxtyping import Float, Int
from scipy import special, stats

#: Pareto-k above which a PSIS estimate is not trusted (Vehtari et al. 2024 for S >= 2000).
PARETO_K_THRESHOLD = 0.7


@dataclass(frozen=True)
class NIGPosterior:
    """Normal-Inverse-Gamma posterior of a linear model (exact, closed form).

    Attributes
    ----------
    mean : ndarray, shape (p,)
        Posterior mean of the coefficients.
    cov_unscaled : ndarray, shape (p, p)
        V_n; the conditional posterior covariance of beta is sigma^2 V_n.
    a, b : float
        Shape and scale of the InvGamma posterior of sigma^2.
    """

    mean: np.ndarray
    cov_unscaled: np.ndarray
    a: float
    b: float


def fit_nig(
    x: Float[np.ndarray, "n p"],
    y: Float[np.ndarray, " n"],
    prior_var: Float[np.ndarray, " p"],
    a0: float = 1.0,
    b0: float = 0.05,
) -> NIGPosterior:
    """Closed-form posterior of ``y = X beta + eps`` under a zero-mean NIG prior.

    Parameters
    ----------
    x : ndarray (n, p)
        Design matrix.
    y : ndarray (n,)
        Outcome.
    prior_var : ndarray (p,)
        Prior variance of each coefficient in units of sigma^2.
    a0, b0 : float
        InvGamma prior of sigma^2.

    Returns
    -------
    NIGPosterior

    Examples
    --------
    >>> x = np.column_stack([np.ones(5), np.arange(5.0)])
    >>> post = fit_nig(x, 1.0 + 2.0 * np.arange(5.0), np.array([100.0, 100.0]))
    >>> bool(abs(post.mean[1] - 2.0) < 0.01)
    True
    """
    prec0 = np.diag(1.0 / prior_var)
    prec_n = prec0 + x.T @ x
    cov_n = np.linalg.inv(prec_n)
    cov_n = 0.5 * (cov_n + cov_n.T)
    mean_n = cov_n @ (x.T @ y)
    a_n = a0 + 0.5 * y.shape[0]
    b_n = b0 + 0.5 * float(y @ y - mean_n @ prec_n @ mean_n)
    return NIGPosterior(mean=mean_n, cov_unscaled=cov_n, a=a_n, b=max(b_n, 1e-12))


def draw_nig(
    post: NIGPosterior, rng: np.random.Generator, n_draws: int
) -> tuple[Float[np.ndarray, "s p"], Float[np.ndarray, " s"]]:
    """Exact independent draws (beta, sigma) from a NIG posterior.

    Examples
    --------
    >>> post = NIGPosterior(np.zeros(1), np.eye(1), 10.0, 10.0)
    >>> beta, sigma = draw_nig(post, np.random.default_rng(0), 100)
    >>> beta.shape, sigma.shape
    ((100, 1), (100,))
    """
    sigma2 = post.b / rng.gamma(post.a, 1.0, n_draws)
    chol = np.linalg.cholesky(post.cov_unscaled + 1e-12 * np.eye(post.mean.shape[0]))
    z = rng.standard_normal((n_draws, post.mean.shape[0]))
    beta = post.mean + np.sqrt(sigma2)[:, None] * (z @ chol.T)
    return beta, np.sqrt(sigma2)


def pointwise_loglik(
    x: Float[np.ndarray, "n p"],
    y: Float[np.ndarray, " n"],
    beta: Float[np.ndarray, "s p"],
    sigma: Float[np.ndarray, " s"],
) -> Float[np.ndarray, "s n"]:
    """Gaussian log-likelihood of every observation under every draw."""
    resid = (y[None, :] - beta @ x.T) / sigma[:, None]
    return -0.5 * resid**2 - np.log(sigma)[:, None] - 0.5 * np.log(2.0 * np.pi)


def exact_logo_logpdf(
    x: Float[np.ndarray, "n p"],
    y: Float[np.ndarray, " n"],
    prior_var: Float[np.ndarray, " p"],
    rows: Int[np.ndarray, " k"],
    a0: float = 1.0,
    b0: float = 0.05,
) -> float:
    """Exact log p(y_rows | y_rest): leave-one(-group)-out predictive (multivariate Student-t).

    Parameters
    ----------
    x, y, prior_var, a0, b0
        As in :func:`fit_nig`.
    rows : ndarray of int
        The rows left out together (one observation, or one segment of a stream).

    Returns
    -------
    float
        Log predictive density of the left-out rows given all others.

    Examples
    --------
    >>> x = np.column_stack([np.ones(6), np.arange(6.0)])
    >>> y = np.array([0.1, 0.9, 2.2, 2.9, 4.1, 5.0])
    >>> bool(np.isfinite(exact_logo_logpdf(x, y, np.array([100.0, 100.0]), np.array([0]))))
    True
    """
    keep = np.ones(y.shape[0], dtype=bool)
    keep[rows] = False
    post = fit_nig(x[keep], y[keep], prior_var, a0, b0)
    xr = x[rows]
    loc = xr @ post.mean
    shape = post.b / post.a * (np.eye(rows.shape[0]) + xr @ post.cov_unscaled @ xr.T)
    return float(stats.multivariate_t.logpdf(y[rows], loc=loc, shape=shape, df=2.0 * post.a))


@dataclass(frozen=True)
class LooResult:
    """PSIS-LOO estimate: total ELPD, its SE, per-unit ELPD and Pareto k.

    ``n_k_high`` counts units whose k exceeded :data:`PARETO_K_THRESHOLD`; ``n_exact`` those whose
    PSIS value was replaced by the exact leave-one-out density (same as ``n_k_high`` when the exact
    replacement was available).
    """

    elpd: float
    se: float
    pointwise: np.ndarray
    pareto_k: np.ndarray
    n_k_high: int
    n_exact: int

    @property
    def k_max(self) -> float:
        return float(np.max(self.pareto_k)) if self.pareto_k.size else float("nan")


def psis_loo_pointwise(
    loglik: Float[np.ndarray, "s n"],
) -> tuple[Float[np.ndarray, " n"], Float[np.ndarray, " n"]]:
    """PSIS-LOO pointwise ELPD and Pareto k from a (draws, units) log-likelihood matrix.

    Uses arviz-stats' ``psislw`` with relative efficiency 1 (exact independent draws); it takes
    the log-likelihood and smooths the log-ratios -loglik.
    """
    log_w, k = array_stats.psislw(loglik.T, r_eff=1.0, axis=-1)
    elpd_i = special.logsumexp(log_w + loglik.T, axis=1)
    return elpd_i, np.asarray(k, dtype=float)


def loo_from_pointwise(
    pointwise: Float[np.ndarray, " n"], pareto_k: Float[np.ndarray, " n"], n_exact: int
) -> LooResult:
    """Assemble a :class:`LooResult` (SE = sqrt(n var(elpd_i)), as in arviz)."""
    n = pointwise.shape[0]
    se = float(np.sqrt(n * np.var(pointwise))) if n > 1 else float("nan")
    return LooResult(
        elpd=float(np.sum(pointwise)),
        se=se,
        pointwise=pointwise,
        pareto_k=pareto_k,
        n_k_high=int(np.sum(pareto_k > PARETO_K_THRESHOLD)),
        n_exact=n_exact,
    )


def difference(base: LooResult, ext: LooResult) -> tuple[float, float]:
    """ELPD gain of ``ext`` over ``base`` and its SE from the paired pointwise differences.

    Examples
    --------
    >>> a = loo_from_pointwise(np.array([-1.0, -1.0, -1.0]), np.zeros(3), 0)
    >>> b = loo_from_pointwise(np.array([-0.5, -0.7, -0.9]), np.zeros(3), 0)
    >>> tuple(round(v, 3) for v in difference(a, b))
    (0.9, 0.283)
    """
    d = ext.pointwise - base.pointwise
    n = d.shape[0]
    se = float(np.sqrt(n * np.var(d))) if n > 1 else float("nan")
    return float(np.sum(d)), se


def ols_rss(x: Float[np.ndarray, "n p"], y: Float[np.ndarray, " n"]) -> tuple[float, int]:
    """Residual sum of squares and rank of an ordinary least-squares fit."""
    coef, _, rank, _ = np.linalg.lstsq(x, y, rcond=None)
    resid = y - x @ coef
    return float(resid @ resid), int(rank)


@dataclass(frozen=True)
class LinearFit:
    """A fitted conjugate linear model: exact posterior, draws and its PSIS-LOO estimate."""

    posterior: NIGPosterior
    beta: np.ndarray
    sigma: np.ndarray
    loo: LooResult


def fit_and_loo(
    x: Float[np.ndarray, "n p"],
    y: Float[np.ndarray, " n"],
    prior_var: Float[np.ndarray, " p"],
    rng: np.random.Generator,
    *,
    n_draws: int = 2000,
    units: Int[np.ndarray, " n"] | None = None,
    exact_fallback: bool = True,
    a0: float = 1.0,
    b0: float = 0.05,
) -> LinearFit:
    """Fit the NIG model, draw from it and estimate leave-one-unit-out ELPD by PSIS.

    Parameters
    ----------
    x, y, prior_var, a0, b0
        As in :func:`fit_nig`.
    rng : numpy.random.Generator
        Source of the posterior draws.
    n_draws : int
        Number of exact posterior draws.
    units : ndarray of int or None
        Unit label (0..U-1) of every row; the log-likelihood is summed per unit so that whole
        units (stream segments) are left out together. ``None``: every row is a unit.
    exact_fallback : bool
        Replace the PSIS value of units with Pareto k > :data:`PARETO_K_THRESHOLD` by the exact
        leave-unit-out density.

    Returns
    -------
    LinearFit

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> x = np.column_stack([np.ones(30), rng.normal(size=30)])
    >>> y = x @ np.array([1.0, 0.5]) + 0.1 * rng.normal(size=30)
    >>> fit = fit_and_loo(x, y, np.array([100.0, 100.0]), rng)
    >>> fit.loo.pointwise.shape
    (30,)
    """
    post = fit_nig(x, y, prior_var, a0, b0)
    beta, sigma = draw_nig(post, rng, n_draws)
    ll = pointwise_loglik(x, y, beta, sigma)
    if units is None:
        unit_rows = None
    else:
        n_units = int(units.max()) + 1
        onehot = np.zeros((y.shape[0], n_units))
        onehot[np.arange(y.shape[0]), units] = 1.0
        ll = ll @ onehot
        unit_rows = [np.flatnonzero(units == u) for u in range(n_units)]
    elpd_i, k = psis_loo_pointwise(ll)
    n_exact = 0
    if exact_fallback:
        for u in np.flatnonzero(k > PARETO_K_THRESHOLD):
            rows = np.array([u]) if unit_rows is None else unit_rows[u]
            elpd_i[u] = exact_logo_logpdf(x, y, prior_var, rows, a0, b0)
            n_exact += 1
    return LinearFit(post, beta, sigma, loo_from_pointwise(elpd_i, k, n_exact))
