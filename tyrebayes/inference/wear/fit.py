"""Fitting the wear model: NUTS, or MAP + Laplace where NUTS takes minutes.

Both return a :class:`~tyrebayes.inference.result.Fit` of kind ``"wear"``; what a prediction
needs from a loaded fit (the sets' tyre types, the type names, the temperature compensation,
baseline or extended) is kept in its data.
"""

from __future__ import annotations

import json

import arviz_base as azb
import jax
import numpy as np
import xarray as xr
from numpyro.infer import SVI, Predictive, Trace_ELBO, init_to_value, log_likelihood
from numpyro.infer.autoguide import AutoLaplaceApproximation
from numpyro.optim import Adam

from ...physics.thermal import StiffnessTemperature
from ..diagnostics import LAPLACE_METHODS
from ..nuts import run_nuts
from ..result import Fit, diagnose, provenance
from .data import WearData, WearPriors
from .model import init_values, wear_model

#: Methods of :func:`fit_wear`.
WEAR_METHODS = ("nuts", "laplace", "fast")
#: Deterministic sites of :func:`wear_model` (not checked for a collapsed covariance).
_DETERMINISTIC_SITES = ("tau", "c_xr", "gamma")


def fit_wear(
    data: WearData,
    extended: bool = False,
    *,
    method: str = "nuts",
    num_warmup: int = 300,
    num_samples: int = 300,
    num_chains: int = 2,
    laplace_steps: int = 4000,
    laplace_draws: int = 1000,
    laplace_learning_rate: float = 0.02,
    seed: int = 0,
    priors: WearPriors | None = None,
    comp: StiffnessTemperature | None = None,
    source: str = "wear data in memory",
) -> Fit:
    """Fit :func:`~tyrebayes.inference.wear.wear_model`; failures are in the diagnostics.

    Parameters
    ----------
    data : WearData
        From :func:`~tyrebayes.inference.wear.build_wear_data`.
    extended : bool
        Add the temperature sensitivity κ of abrasability per tyre type.
    method : {"nuts", "laplace", "fast"}
        NUTS (dense mass: the data fix γ / C_xr, a correlated ridge), or the MAP by Adam with a
        decaying step followed by a Gaussian at the mode (Hessian covariance): NUTS needs
        minutes on a small machine along that ridge, the Laplace approximation captures the
        correlation at the cost of a few thousand gradient steps. ``"fast"`` is the same fit
        (recorded as ``"laplace"``): :data:`~tyrebayes.inference.diagnostics.FIT_METHODS`.
    num_warmup, num_samples, num_chains
        NUTS settings; two chains (:data:`~tyrebayes.inference.diagnostics.FIT_METHODS` says
        why).
    laplace_steps, laplace_draws, laplace_learning_rate
        Laplace settings: Adam steps, draws, first step size (decays to 1 % of it).
    seed : int
    priors : WearPriors, optional
    comp : StiffnessTemperature, optional
        Temperature compensation of C_x (default :class:`StiffnessTemperature`).
    source : str
        Where the data came from (provenance).

    Returns
    -------
    Fit
        ``kind="wear"``; diagnostics under :data:`~tyrebayes.inference.result.POLICY` over
        ``mu_log_gamma``, ``gamma``, ``c_xr`` (and ``kappa``); for the Laplace path, whether the
        loss settled (less than 1e-4 relative change between the last two tenths of the run) and
        the covariance is finite and not collapsed. ``adequate`` is True with no reasons: the wear
        fit runs no predictive check of its own (compare models by
        :func:`~tyrebayes.inference.result.loo` of ``"depth"``).
    """
    if method not in WEAR_METHODS:
        raise ValueError(f"method: expected one of {WEAR_METHODS}, got {method!r}")
    method = "laplace" if method in LAPLACE_METHODS else method  # one word in the fit
    comp = StiffnessTemperature() if comp is None else comp
    priors = WearPriors() if priors is None else priors
    if method == "nuts":
        samples, loglik, stats = _run_nuts(
            data, extended, priors, comp, num_warmup, num_samples, num_chains, seed
        )
        info, result, problems = {}, "n/a", []
        settings = {"num_warmup": num_warmup, "num_samples": num_samples, "num_chains": num_chains}
    else:
        samples, loglik, info, result, problems = _run_laplace(
            data, extended, priors, comp, seed, laplace_steps, laplace_draws, laplace_learning_rate
        )
        stats = None
        settings = {"laplace_steps": laplace_steps, "laplace_draws": laplace_draws}
    tree = _to_datatree(samples, loglik, stats, data, extended, comp, info)
    names = ["mu_log_gamma", "gamma", "c_xr"] + (["kappa"] if extended else [])
    diagnostics = diagnose(
        tree, method=method, var_names=names, optimiser_result=result, problems=problems
    )
    return Fit(
        data=tree,
        diagnostics=diagnostics,
        kind="wear",
        provenance=provenance(
            method, "extended" if extended else "baseline", (source,), seed=seed, **settings
        ),
    )


def _run_nuts(data, extended, priors, comp, num_warmup, num_samples, num_chains, seed):
    # dense mass: wear data fix gamma / C_xr, so (log gamma, log C_xr) is a correlated ridge
    draws = run_nuts(
        wear_model,
        (data, extended, priors, comp),
        seed=seed,
        num_warmup=num_warmup,
        num_samples=num_samples,
        num_chains=num_chains,
        init_values=init_values(data, extended, priors),
        target_accept_prob=0.95,
        dense_mass=True,
        max_tree_depth=8,
    )
    # Built by hand: the converter re-traces the model with random draws, which trips the strict
    # rank promotion this package runs with.
    loglik = log_likelihood(wear_model, draws.flat(), data, extended, priors, comp)
    loglik = {k: np.asarray(v).reshape((num_chains, -1) + v.shape[1:]) for k, v in loglik.items()}
    return draws.samples, loglik, {"diverging": draws.diverging}


def _run_laplace(data, extended, priors, comp, seed, steps, num_draws, learning_rate):
    """MAP by Adam and a Gaussian at the mode: ``(samples, loglik, info, result, problems)``."""
    guide = AutoLaplaceApproximation(
        wear_model, init_loc_fn=init_to_value(values=init_values(data, extended, priors))
    )

    # Exponentially decaying step (to 1 % of the start): the MAP search settles instead of
    # circling the mode at a constant step size.
    def step_size(i):
        return learning_rate * 0.01 ** (i / steps)

    svi = SVI(wear_model, guide, Adam(step_size), Trace_ELBO())
    key_fit, key_draw, key_det = jax.random.split(jax.random.PRNGKey(seed), 3)
    result = svi.run(key_fit, steps, data, extended, priors, comp, progress_bar=False)
    losses = np.asarray(result.losses)
    tenth = max(len(losses) // 10, 1)
    last, before = losses[-tenth:].mean(), losses[-2 * tenth : -tenth].mean()
    settled = bool(np.isfinite(last) and abs(last - before) <= 1e-4 * max(abs(last), 1.0))

    # Jitted as a whole: run eagerly, the Hessian and the vmapped log densities dispatch (and
    # compile) hundreds of single operations.
    @jax.jit
    def draws_and_loglik(params, key_draw, key_det):
        latent = guide.sample_posterior(key_draw, params, sample_shape=(num_draws,))
        det = Predictive(
            wear_model, posterior_samples=latent, return_sites=["c_xr", "gamma", "tau"]
        )(key_det, data, extended, priors, comp)
        return latent, det, log_likelihood(wear_model, latent, data, extended, priors, comp)

    # numpyro's MultivariateNormal.sample broadcasts loc (k,) against (draws, k): allowed here
    # even where the package runs with strict rank promotion.
    with jax.numpy_rank_promotion("allow"):
        latent, det, loglik = draws_and_loglik(result.params, key_draw, key_det)
    finite = all(bool(np.all(np.isfinite(np.asarray(v)))) for v in latent.values())
    # a collapsed covariance (MAP at a boundary) gives draws without spread: not a posterior
    # (the guide also returns the model's deterministic sites; τ is a constant 0 without pooling)
    degenerate = any(
        bool(np.any(np.std(np.asarray(v), axis=0) < 1e-12))
        for k, v in latent.items()
        if k not in _DETERMINISTIC_SITES
    )
    samples = {k: np.asarray(v)[None] for k, v in {**latent, **det}.items()}
    loglik = {k: np.asarray(v)[None] for k, v in loglik.items()}
    problems = ["degenerate covariance (mode at a boundary)"] if degenerate else []
    if not finite:
        problems.append("non-finite draws")
    result = "successful" if settled else "loss still changing at the end of the run"
    return samples, loglik, {"final_loss": float(last)}, result, problems


def _to_datatree(samples, loglik, stats, data, extended, comp, info) -> xr.DataTree:
    observed = {}
    if data.depth_mm.size:
        observed["depth"] = data.depth_mm
    if data.drift_mask.any():
        observed["drift_permille"] = 1e3 * data.drift[data.drift_mask]
    groups = {
        "posterior": samples,
        "log_likelihood": loglik,
        "observed_data": observed,
        "constant_data": {"set_type": np.asarray(data.set_type)},
    }
    if stats is not None:
        groups["sample_stats"] = stats
    tree = azb.from_dict(groups)
    tree.attrs.update(
        {
            "type_names": json.dumps(list(data.type_names)),
            "extended": int(bool(extended)),
            "stiffness_temperature": json.dumps({k: float(getattr(comp, k)) for k in _COMP_FIELDS}),
            "laplace": json.dumps(info),
        }
    )
    return tree


_COMP_FIELDS = (
    "sensitivity_per_k",
    "reference_stiffness",
    "stiffness_exponent",
    "reference_temperature_c",
)


def wear_fit_parts(fit: Fit) -> tuple[tuple[str, ...], np.ndarray, bool, StiffnessTemperature]:
    """``(type_names, set_type, extended, comp)`` of a wear fit (made here or loaded)."""
    if fit.kind != "wear":
        raise ValueError(f"fit: expected a wear fit, got a {fit.kind} fit")
    comp = StiffnessTemperature(**fit.attr("stiffness_temperature"))
    set_type = np.asarray(fit.data["constant_data"]["set_type"], int)
    return tuple(fit.attr("type_names")), set_type, bool(fit.data.attrs["extended"]), comp
