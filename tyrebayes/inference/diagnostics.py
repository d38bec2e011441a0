"""Whether a fit can be trusted: one diagnostics function under one policy, for every fit.

:func:`diagnose` is the only place in the package where R-hat and effective sample sizes are
computed (arviz-stats), judged by :data:`POLICY`; :func:`posterior_predictive_adequacy` is the
simple model check the fleet fit runs; :func:`loo` and :func:`hdi` wrap arviz-stats once.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Sequence

import arviz_stats as azs
import equinox as eqx
import numpy as np
import xarray as xr

#: The fit methods: every fitter's ``method=`` takes these words, and every fit records one of
#: them in ``Diagnostics.method`` and ``Provenance.method``. Randomness enters every fitter as
#: ``seed: int``.
#:
#: Default chain counts: 4 for a tyre fit, the number for which Vehtari et al. (2021) set their
#: R-hat advice, affordable because a tyre posterior has a handful of parameters (seconds per
#: chain); 2 for the fleet, wear and wear-history fits, whose chains take minutes on a small
#: machine, which is why :data:`POLICY` allows an R-hat of 1.02 rather than 1.01.
FIT_METHODS: dict[str, str] = {
    "nuts": "NUTS (numpyro): Markov chains; R-hat, ESS and divergences judge convergence",
    "laplace": (
        "MAP by an optimiser, then independent draws from a Gaussian at the mode with the "
        "inverse Hessian as covariance; the optimiser's result judges convergence "
        "(fit_tyre, fit_wear)"
    ),
    "fast": (
        "the tyre fit's name for 'laplace' (BFGS to the MAP, Laplace draws), kept by the "
        "command line (--method fast) and the tyre fits it saved; fit_tyre and fit_wear take "
        "either word"
    ),
    "svi": (
        "mean-field stochastic variational inference (numpyro AutoNormal), independent draws "
        "of the guide; for fleets of thousands of sets (fit_fleet)"
    ),
}
#: The words :data:`FIT_METHODS` that name the same MAP + Laplace fit.
LAPLACE_METHODS: tuple[str, ...] = ("laplace", "fast")
#: Methods whose draws are Markov chains (R-hat, ESS and divergences apply).
MCMC_METHODS: tuple[str, ...] = ("nuts",)
#: Methods whose draws are independent draws of an approximation (MAP + Laplace, SVI): there
#: the optimiser's result decides convergence and the ESS is the number of draws.
APPROXIMATE_METHODS: tuple[str, ...] = ("fast", "laplace", "svi")


class ConvergencePolicy(eqx.Module):
    """When a fit counts as converged: the one policy of the package (:data:`POLICY`).

    Attributes
    ----------
    r_hat_max : float
        Largest rank-normalised split R-hat allowed: 1.02. Vehtari et al. (2021) recommend 1.01
        for four chains; the fleet and wear fits run two, and the largest of some thirty R-hats
        of two well-mixed chains with a bulk ESS of ~500 exceeds 1.01 by chance (measured: 1.016
        on a simulated 120-set fleet). 1.02 still flags chains whose means disagree by more than
        about a quarter of a posterior sd.
    ess_bulk_min_per_chain, ess_tail_min_per_chain : float
        Smallest bulk and tail effective sample size allowed, per chain (their 100 per chain:
        400 with four chains).
    divergence_max_fraction : float
        Largest fraction of divergent NUTS transitions allowed: 0.1 %, one in a thousand draws.
        A lone divergence in a hierarchical posterior is usually a step into the tail of a
        scale parameter; more mean a region the sampler cannot reach.

    Examples
    --------
    >>> POLICY.r_hat_max
    1.02
    >>> ConvergencePolicy(r_hat_max=1.01).r_hat_max  # Vehtari et al.'s for four chains
    1.01
    """

    r_hat_max: float = 1.02
    ess_bulk_min_per_chain: float = 100.0
    ess_tail_min_per_chain: float = 100.0
    divergence_max_fraction: float = 0.001

    def __check_init__(self):
        if not self.r_hat_max >= 1.0:
            raise ValueError(f"r_hat_max: expected >= 1, got {self.r_hat_max}")
        for name in ("ess_bulk_min_per_chain", "ess_tail_min_per_chain"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name}: expected >= 0, got {getattr(self, name)}")
        if not 0.0 <= self.divergence_max_fraction <= 1.0:
            raise ValueError(
                f"divergence_max_fraction: expected in [0, 1], got {self.divergence_max_fraction}"
            )


#: The policy every fit is judged by.
POLICY = ConvergencePolicy()


class Diagnostics(eqx.Module):
    """Whether a fit can be trusted (converged) and whether its model describes its data (adequate).

    Build with :func:`diagnose`; never raised, always returned with the fit.

    Attributes
    ----------
    method : str
        One of :data:`FIT_METHODS`.
    n_chains, n_draws : int
        Chains and draws per chain of the posterior.
    r_hat_max : float
        Largest rank-normalised split R-hat over the checked variables (NaN where it does not
        apply: one chain, or independent draws).
    ess_bulk_min, ess_tail_min : float
        Smallest bulk and tail effective sample size over the checked variables (the number of
        draws for independent draws).
    divergences : int
        Divergent NUTS transitions (0 for other methods).
    optimiser_result : str
        ``"successful"`` or the optimiser's failure (MAP, SVI); ``"n/a"`` for NUTS.
    converged : bool
        Every check of :data:`POLICY` passed.
    reasons : tuple of str
        Why ``converged`` is False (empty otherwise).
    adequate : bool
        The model describes the data (posterior predictive checks, variance inflation); True
        with no reasons where a fitter runs no such check.
    adequacy_reasons : tuple of str
        Why ``adequate`` is False, or what was found short of that.

    Examples
    --------
    >>> import arviz_base as azb
    >>> draws = np.random.default_rng(0).normal(30.0, 1.0, (1, 400))
    >>> tree = azb.from_dict({"posterior": {"c_xr": draws}})
    >>> d = diagnose(tree, method="laplace", optimiser_result="successful")
    >>> d.converged, d.n_draws, Diagnostics.from_dict(d.as_dict()).method
    (True, 400, 'laplace')
    """

    method: str
    n_chains: int
    n_draws: int
    r_hat_max: float
    ess_bulk_min: float
    ess_tail_min: float
    divergences: int
    optimiser_result: str
    converged: bool
    reasons: tuple[str, ...]
    adequate: bool = True
    adequacy_reasons: tuple[str, ...] = ()

    @property
    def reason(self) -> str:
        """The reasons for non-convergence as one line ("" when converged)."""
        return "; ".join(self.reasons)

    @property
    def ess_min(self) -> float:
        """The smaller of bulk and tail ESS."""
        return float(np.fmin(self.ess_bulk_min, self.ess_tail_min))

    @property
    def short_of_draws(self) -> bool:
        """Whether too few effective draws (bulk or tail ESS) are the only failure: chains that
        agree (R-hat) and did not diverge, mixing slowly, which more draws can cure.

        Examples
        --------
        >>> import arviz_base as azb
        >>> rng = np.random.default_rng(0)
        >>> few = azb.from_dict({"posterior": {"x": rng.normal(size=(2, 60))}})
        >>> d = diagnose(few, method="nuts")
        >>> d.reasons, d.short_of_draws
        (('bulk ESS 109 < 200', 'tail ESS 99 < 200'), True)
        """
        return not self.converged and all(
            r.startswith(("bulk ESS", "tail ESS")) for r in self.reasons
        )

    def as_dict(self) -> dict:
        """The JSON form (``--json`` and the saved file): plain numbers, strings and lists."""
        return {
            "method": self.method,
            "n_chains": int(self.n_chains),
            "n_draws": int(self.n_draws),
            "r_hat_max": float(self.r_hat_max),
            "ess_bulk_min": float(self.ess_bulk_min),
            "ess_tail_min": float(self.ess_tail_min),
            "divergences": int(self.divergences),
            "optimiser_result": self.optimiser_result,
            "converged": bool(self.converged),
            "reasons": list(self.reasons),
            "adequate": bool(self.adequate),
            "adequacy_reasons": list(self.adequacy_reasons),
        }

    @classmethod
    def from_dict(cls, d: dict) -> Diagnostics:
        """Inverse of :meth:`as_dict` (a loaded fit's diagnostics)."""

        def number(x):
            return float("nan") if x is None else float(x)

        return cls(
            method=str(d["method"]),
            n_chains=int(d["n_chains"]),
            n_draws=int(d["n_draws"]),
            r_hat_max=number(d["r_hat_max"]),
            ess_bulk_min=number(d["ess_bulk_min"]),
            ess_tail_min=number(d["ess_tail_min"]),
            divergences=int(d["divergences"]),
            optimiser_result=str(d["optimiser_result"]),
            converged=bool(d["converged"]),
            reasons=tuple(d["reasons"]),
            adequate=bool(d["adequate"]),
            adequacy_reasons=tuple(d["adequacy_reasons"]),
        )

    def with_adequacy(self, reasons: Sequence[str], *, adequate: bool | None = None) -> Diagnostics:
        """These diagnostics with the model-adequacy verdict of a posterior predictive check.

        ``adequate`` defaults to "no reasons".
        """
        reasons = tuple(reasons)
        ok = not reasons if adequate is None else bool(adequate)
        return dataclasses.replace(self, adequate=ok, adequacy_reasons=reasons)


def _extreme(values: xr.DataTree | xr.Dataset, reduce) -> float:
    ds = values.dataset if isinstance(values, xr.DataTree) else values
    found = [reduce(np.asarray(ds[v], float)) for v in ds.data_vars]
    found = [x for x in found if np.isfinite(x)]
    return float(reduce(np.asarray(found))) if found else float("nan")


def diagnose(
    data: xr.DataTree,
    *,
    method: str,
    var_names: Sequence[str] | None = None,
    coords: dict | None = None,
    optimiser_result: str = "n/a",
    problems: Sequence[str] = (),
    policy: ConvergencePolicy = POLICY,
) -> Diagnostics:
    """Diagnostics of a fit's posterior under ``policy``: the one place R-hat and ESS are computed.

    Parameters
    ----------
    data : xarray.DataTree
        The fit's ArviZ data; ``posterior`` (chain, draw, ...) is required, ``sample_stats`` with
        ``diverging`` is read where present.
    method : str
        One of :data:`MCMC_METHODS` (R-hat, bulk and tail ESS, divergences are checked) or
        :data:`APPROXIMATE_METHODS` (independent draws: the ESS is the number of draws and
        ``optimiser_result`` decides).
    var_names : sequence of str, optional
        The variables to check (default: all of the posterior). Deterministic functions of
        others, and variables without posterior uncertainty, are best left out.
    coords : dict, optional
        A selection of the checked variables' coordinates (e.g. the surfaces a fleet had data
        on; the others hold prior draws).
    optimiser_result : str
        ``"successful"`` or the failure of the optimiser (approximate methods); "n/a" otherwise.
    problems : sequence of str
        Further reasons the fit failed, found by the fitter (a Hessian that is not positive
        definite, non-finite draws).
    policy : ConvergencePolicy
        Thresholds (default :data:`POLICY`).

    Returns
    -------
    Diagnostics
        ``adequate`` is True with no reasons; a fitter that checks its model adds its verdict with
        :meth:`Diagnostics.with_adequacy`.

    Examples
    --------
    >>> import arviz_base as azb
    >>> rng = np.random.default_rng(0)
    >>> dt = azb.from_dict({"posterior": {"x": rng.normal(size=(4, 500))}})
    >>> diagnose(dt, method="nuts").converged
    True
    """
    if method not in MCMC_METHODS + APPROXIMATE_METHODS:
        raise ValueError(
            f"method: expected one of {MCMC_METHODS + APPROXIMATE_METHODS}, got {method!r}"
        )
    if "posterior" not in data.children:
        raise ValueError(f"data: expected a 'posterior' group, got groups {list(data.children)}")
    post = data["posterior"]
    names = list(post.data_vars) if var_names is None else list(var_names)
    missing = [v for v in names if v not in post.data_vars]
    if missing:
        raise ValueError(f"var_names: expected posterior variables, got unknown {missing}")
    n_chains, n_draws = int(post.sizes["chain"]), int(post.sizes["draw"])
    reasons = list(problems)
    divergences = 0
    if method in MCMC_METHODS:
        stats = data.children.get("sample_stats")
        if stats is not None and "diverging" in stats.data_vars:
            divergences = int(np.asarray(stats["diverging"]).sum())
        with warnings.catch_warnings():
            # Constant variables (a pinned hyper-parameter) give NaN R-hat with a warning; they
            # are skipped by _extreme.
            warnings.simplefilter("ignore")
            ess_bulk = _extreme(
                azs.ess(data, var_names=names, coords=coords, method="bulk"), np.nanmin
            )
            ess_tail = _extreme(
                azs.ess(data, var_names=names, coords=coords, method="tail"), np.nanmin
            )
            r_hat = (
                _extreme(azs.rhat(data, var_names=names, coords=coords), np.nanmax)
                if n_chains > 1
                else float("nan")
            )
        if n_chains > 1 and not r_hat <= policy.r_hat_max:
            reasons.append(f"R-hat {r_hat:.3f} > {policy.r_hat_max}")
        if not ess_bulk >= policy.ess_bulk_min_per_chain * n_chains:
            reasons.append(
                f"bulk ESS {ess_bulk:.0f} < {policy.ess_bulk_min_per_chain * n_chains:.0f}"
            )
        if not ess_tail >= policy.ess_tail_min_per_chain * n_chains:
            reasons.append(
                f"tail ESS {ess_tail:.0f} < {policy.ess_tail_min_per_chain * n_chains:.0f}"
            )
        allowed = math.floor(policy.divergence_max_fraction * n_chains * n_draws)
        if divergences > allowed:
            reasons.append(f"{divergences} divergent transitions (allowed {allowed})")
    else:
        r_hat = float("nan")
        ess_bulk = ess_tail = float(n_chains * n_draws)
        if optimiser_result != "successful":
            reasons.append(f"optimiser: {optimiser_result}")
        finite = all(np.all(np.isfinite(np.asarray(post[v], float))) for v in names)
        if not finite:
            reasons.append("non-finite draws")
    return Diagnostics(
        method=method,
        n_chains=n_chains,
        n_draws=n_draws,
        r_hat_max=r_hat,
        ess_bulk_min=ess_bulk,
        ess_tail_min=ess_tail,
        divergences=divergences,
        optimiser_result=optimiser_result,
        converged=not reasons,
        reasons=tuple(dict.fromkeys(reasons)),
    )


def posterior_predictive_adequacy(
    data: xr.DataTree, var_name: str, *, tail_probability: float = 0.005
) -> tuple[str, ...]:
    """A simple posterior predictive check of one observed variable; reasons it fails.

    Compares the observed mean and standard deviation with their posterior predictive
    distributions; a Bayesian p-value below ``tail_probability`` or above ``1 - tail_probability``
    is a reason. Returns ``()`` when the check passes or the data hold no predictive group.
    """
    groups = data.children
    if "posterior_predictive" not in groups or "observed_data" not in groups:
        return ()
    y = np.asarray(data["observed_data"][var_name], float).ravel()
    rep = np.asarray(data["posterior_predictive"][var_name], float)
    rep = rep.reshape(-1, y.size)
    reasons = []
    for name, stat in (("mean", np.mean), ("sd", np.std)):
        p = float(np.mean(stat(rep, axis=1) >= stat(y)))
        if not tail_probability <= p <= 1 - tail_probability:
            reasons.append(
                f"{var_name}: observed {name} outside its posterior predictive (p = {p:.3f})"
            )
    return tuple(reasons)


def loo(
    data: xr.DataTree,
    var_name: str | None = None,
    *,
    pointwise: bool = True,
    reff: float | None = None,
):
    """PSIS-LOO of a fit's log-likelihood (arviz-stats), its Pareto-k warnings kept as data.

    ``reff`` is the relative efficiency of the draws (default: estimated from the posterior's
    ESS; 1 for exact independent draws).

    The warning arviz-stats raises for large Pareto k is dropped: the returned ``pareto_k``
    carries the same information for the caller to judge.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return azs.loo(data, var_name=var_name, pointwise=pointwise, reff=reff)


def hdi(x: np.ndarray, prob: float) -> tuple[float, float]:
    """Highest-density interval of 1-D draws (arviz-stats)."""
    lo, hi = np.asarray(azs.hdi(np.asarray(x, float), prob=prob))
    return float(lo), float(hi)
