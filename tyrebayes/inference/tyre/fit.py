"""Fitting the per-tyre model: full NUTS or a fast MAP + Laplace path, one result type.

Both return a :class:`TyreFit` whose ``idata`` is ArviZ data (a ``DataTree``) with posterior,
observed data, constant data and (unless ``pointwise=False``) log-likelihood and posterior
predictive groups, and whose ``diagnostics`` say
whether the fit can be trusted. A fit that did not converge says so (``converged=False``); it is
returned as data, never raised and never hidden.

The engines live beside it: :mod:`.tyre_laplace` (MAP search, Hessian, Laplace draws),
:mod:`.tyre_nuts` (NUTS in whitened coordinates), :mod:`.tyre_predictive` (stored
log-likelihood, posterior predictive, the ArviZ data) and :mod:`.tyre_result` (:class:`TyreFit`).
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ...internal.device_arrays import device_array
from ...internal.renamed import renamed_keyword
from ..diagnostics import LAPLACE_METHODS
from .adequacy import Adequacy, assess_adequacy, likelier_surface
from .data import TyreObservations
from .laplace import LaplaceCore, _laplace_core, optimiser_outcome
from .model import (
    DEFAULT_MODEL,
    SURFACES,
    TyrePriors,
    check_model,
    curve_slip,
    window_likelihood,
)
from .nuts import _nuts_runner
from .predictive import (
    _obs_key,
    _priors_key,
    _scalar_diagnostics,
    _to_inference_data,
)
from .result import TyreFit
from .window_correlation import slip_weights

# μ_max counts as observed on a surface only where the drive reached the limit (ABS windows) and
# the posterior sd of log μ_max is below half the prior sd. Without ABS windows the curvature of
# the linear region narrows μ_max only through the assumed brush shape, which real tyres do not
# follow closely enough to call that an observation of the peak.
MU_OBSERVED_CONTRACTION = 0.5
# Laplace draws of the fast path (NUTS compiles the same Laplace core for its whitening).
LAPLACE_DRAWS = 2000


def _mu_observed(fit_draws: np.ndarray, priors: TyrePriors, obs: TyreObservations) -> dict:
    log_sd = np.std(np.log(fit_draws), axis=0)
    contraction = 1.0 - log_sd / np.asarray(priors.mu_log_sd(obs.surfaces))
    at_limit = np.asarray(obs.mask) & np.asarray(obs.at_limit)
    surface = np.asarray(obs.surface_index)
    return {
        s: bool(at_limit[surface == i].any() and contraction[i] >= MU_OBSERVED_CONTRACTION)
        for i, s in enumerate(obs.surfaces)
    }


def _tyre_fit(
    idata, diagnostics, samples: dict, priors, obs: TyreObservations, model: str, inflation
) -> TyreFit:
    """The result both fitting paths return."""
    slip_window = np.asarray(obs.mask) & ~np.asarray(obs.at_limit)
    rho = np.asarray(obs.rho)[slip_window]
    rho = rho[np.isfinite(rho)]
    force_range = float(np.quantile(np.abs(rho), 0.9)) if rho.size else 0.0
    # A fit that did not converge may carry non-finite or zero draws: its diagnostics say so
    # ("non-finite draws"), and NumPy's warnings on their logarithms would add nothing.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        mu_observed = _mu_observed(samples["mu_max"], priors, obs)
        adequacy = _adequacy(obs, samples, model, priors, mu_observed)
    return TyreFit(
        idata=idata,
        diagnostics=diagnostics.with_adequacy(adequacy.reasons),
        mu_observed=mu_observed,
        surfaces=obs.surfaces,
        n_samples_used=obs.n_used,
        model=model,
        slip_variance_inflation=tuple(float(x) for x in inflation),
        adequacy=adequacy,
        force_range=force_range,
        secant_stiffness=_secant_stiffness(samples, model, force_range),
    )


# Compiled as one program, not op by op; given the curve's shape sites alone (their draws have
# one shape for every fit, where the per-drive sites' depend on the number of drives).
_draws_slip = eqx.filter_jit(curve_slip)
_CURVE_SHAPE_SITES = ("curve_shape", "curve_shape_c", "curve_curvature_e")


def _secant_stiffness(samples: dict, model: str, force: float) -> np.ndarray:
    """Draws of ρ/σ(ρ) of the fitted curve at ``force`` (first surface, C_x at the mean T)."""
    if force <= 0:
        return np.asarray(samples["c_x"], float)
    mu = np.asarray(samples["mu_max"])[:, 0]
    force = np.minimum(force, 0.999 * mu)
    shape = {k: samples[k] for k in _CURVE_SHAPE_SITES if k in samples}
    slip = np.asarray(_draws_slip(model, np.asarray(force), samples["c_x"], mu, shape))
    with np.errstate(invalid="ignore", divide="ignore"):
        return force / slip


@eqx.filter_jit
def _point_residuals(
    point: dict, obs: TyreObservations, model: str
) -> tuple[Float[Array, " n"], Float[Array, " n"]]:
    """Each window's slip residual σ_obs − loc at one point θ, and the residual standardised
    with the block offset taken out, (σ_obs − loc − offset)/scale (:func:`window_likelihood`).

    Compiled as one program per data shape: run op by op, its hundred-odd operations were each
    a program of its own, traced, lowered and looked up in the compilation cache at every new
    padded shape (a fleet worker's first fit of a shape).
    """
    lik = window_likelihood(point, obs, model)
    residual = obs.slip - lik.slip_loc
    return residual, (residual - lik.block_offset) / lik.slip_scale


def _adequacy(
    obs: TyreObservations, samples: dict, model: str, priors: TyrePriors, mu_observed: dict
) -> Adequacy:
    """:func:`.adequacy.assess_adequacy` at the posterior mean (slip windows, time order)."""
    point = {k: np.mean(np.asarray(v), axis=0) for k, v in samples.items()}
    residual, z = (np.asarray(x) for x in _point_residuals(point, obs, model))
    slip_window = np.asarray(obs.mask) & ~np.asarray(obs.at_limit)
    z = z[slip_window]
    shape_sds = {}
    if model == "magic":
        shape_sds = {
            "shape C": (
                float(np.mean(np.log(samples["curve_shape_excess"])))
                - priors.curve_shape_excess_log_mean
            )
            / priors.curve_shape_excess_log_sd,
            "curvature E": (
                float(np.mean(np.log(samples["curve_curvature_gap"])))
                - priors.curve_curvature_log_mean
            )
            / priors.curve_curvature_log_sd,
        }
    drives = np.asarray(obs.drive_index)[slip_window]
    blocks = np.asarray(obs.block_index)[slip_window]
    # Each block's mean slip residual (the model's block offset included where it has them):
    # a step in it is a change of tyre or radius. Blocks are numbered in time order.
    residual = residual[slip_window]
    per_drive = []
    for d in range(obs.n_drives):
        ids, inverse = np.unique(blocks[drives == d], return_inverse=True)
        sums = np.bincount(inverse, residual[drives == d], minlength=len(ids))
        per_drive.append(sums / np.bincount(inverse, minlength=len(ids)))
    label_odds = {
        s: _likelier_surface(np.log(samples["mu_max"][:, i]), s, priors)
        for i, s in enumerate(obs.surfaces)
        if mu_observed[s]
    }
    return assess_adequacy(
        z,
        np.asarray(obs.rho)[slip_window],
        drives,
        obs.n_drives,
        shape_prior_sds=shape_sds,
        block_offsets=tuple(per_drive),
        c_xr_prior_sds=(float(np.mean(np.log(samples["c_xr"]))) - np.log(priors.c_xr_median))
        / priors.c_xr_log_sd,
        mu_prior_sds={
            s: float(
                (np.mean(np.log(samples["mu_max"][:, i])) - np.log(priors.mu_median((s,))[0]))
                / priors.mu_log_sd((s,))[0]
            )
            for i, s in enumerate(obs.surfaces)
            if mu_observed[s]
        },
        # No entry where no surface is grippier than the label (dry).
        mu_likelier_surface={s: odds for s, odds in label_odds.items() if np.isfinite(odds[1])},
    )


def _likelier_surface(log_mu: np.ndarray, label: str, priors: TyrePriors) -> tuple[str, float]:
    """:func:`.adequacy.likelier_surface` of posterior draws of log μ_max, by surface name."""
    best, lbf = likelier_surface(
        float(np.mean(log_mu)),
        float(np.std(log_mu)),
        label,
        SURFACES,
        np.log(np.asarray(priors.mu_median(SURFACES))),
        np.asarray(priors.mu_log_sd(SURFACES)),
    )
    return SURFACES[int(best)], float(lbf)


def _weighted_by_correlation(obs: TyreObservations, point: dict, model: str):
    """``obs`` with each drive's slip weight 1/VIF from the residuals at ``point``.

    Returns ``(obs, inflation)``. The weights change the posterior's width, not its centre
    (to first order), so the mode of a first fit with unit weights gives residuals good enough
    for them. Where they are the weights ``obs`` has (every drive's VIF 1), ``obs`` itself is
    returned.
    """
    z = np.asarray(_point_residuals({k: device_array(v) for k, v in point.items()}, obs, model)[1])
    slip_window = np.asarray(obs.mask) & ~np.asarray(obs.at_limit)
    weights, inflation = slip_weights(z, slip_window, np.asarray(obs.drive_index), obs.n_drives)
    if np.array_equal(weights, np.asarray(obs.slip_weight)):
        return obs, inflation
    weighted = dataclasses.replace(obs, slip_weight=device_array(weights, obs.slip.dtype))
    return weighted, inflation


def _second_pass(core: LaplaceCore, first: tuple, obs: TyreObservations, weighted):
    """The mode and outcome code on the weighted observations, refitted from the first pass's.

    ``first`` is the first pass's ``core.mode`` result. Unchanged weights give the same
    posterior: its mode and outcome are kept (a BFGS run started exactly at its own optimum
    only wanders in round-off, for seconds).
    """
    mode, code, whiten, _ = first
    if weighted is obs:
        return mode, code
    return core.mode(mode, weighted, whiten, False)[:2]


def _first_pass(core: LaplaceCore, obs: TyreObservations, model: str):
    """The searched mode with unit slip weights, and the weighted observations it gives.

    Returns ``(first, weighted, inflation)``: ``first`` the ``core.mode`` result, ``weighted``
    ``obs`` with each drive's slip weight 1/VIF (``obs`` itself where every VIF is 1).
    """
    identity = device_array(np.eye(core.flat0.shape[0]), core.flat0.dtype)
    first = core.mode(core.flat0, obs, identity, True)
    weighted, inflation = _weighted_by_correlation(obs, first[3], model)
    return first, weighted, inflation


@renamed_keyword("kind", "model", what="the tyre-curve model")
def fit_tyre_nuts(
    obs: TyreObservations,
    *,
    priors: TyrePriors | None = None,
    model: str = DEFAULT_MODEL,
    num_chains: int = 4,
    num_warmup: int = 300,
    num_samples: int = 1000,
    seed: int = 0,
    pointwise: bool = True,
) -> TyreFit:
    """Full NUTS fit (``num_chains`` chains, one per CPU device at a time) in whitened coordinates.

    Why whitened: with thousands of windows the posterior is narrow and its scales differ by
    orders of magnitude (a slip offset known to 1e-5, a ratio to 1e-1). NUTS started at the prior
    and adapting a mass matrix from the identity then spends its warm-up at maximum tree depth,
    and the adaptation's regularisation towards 1e-3·I swamps the smallest variances. So the MAP
    and Hessian of the fast path come first, and NUTS samples u with z = mode + S u (S S' = H⁻¹):
    u is close to standard normal where the Laplace approximation holds, and the dense mass
    matrix adapted in u corrects it where it does not. Chains start at overdispersed draws
    (2× the Laplace scale) so that R-hat can see chains that do not mix.

    Convergence: :data:`tyrebayes.inference.result.POLICY` (R-hat, bulk and tail ESS,
    divergences), judged by :func:`~tyrebayes.inference.result.diagnose`. Compiled once per data
    shape (padded bucket, drives, surfaces) and sampler settings.
    """
    priors = TyrePriors() if priors is None else priors
    check_model(model)
    key_laplace, key_init, key_run, key_ppc = jax.random.split(jax.random.PRNGKey(seed), 4)
    core = _laplace_core(_priors_key(priors), model, _obs_key(obs), LAPLACE_DRAWS, 2000)
    first, weighted, inflation = _first_pass(core, obs, model)
    mode, _ = _second_pass(core, first, obs, weighted)
    obs = weighted
    _, scale, _ = core.laplace(mode, obs, key_laplace)
    runner = _nuts_runner(
        _priors_key(priors), model, _obs_key(obs), num_chains, num_warmup, num_samples
    )
    u_init = 2.0 * jax.random.normal(key_init, (num_chains, mode.shape[0]), dtype=mode.dtype)
    samples, diverging = runner(key_run, obs, mode, scale, u_init)
    samples = {k: np.asarray(v) for k, v in samples.items()}
    diverging = np.asarray(diverging).reshape(num_chains, -1)
    idata = _to_inference_data(
        samples,
        num_chains,
        obs,
        model,
        key_ppc,
        sample_stats={"diverging": diverging},
        pointwise=pointwise,
    )
    diagnostics = _scalar_diagnostics(idata)
    return _tyre_fit(idata, diagnostics, samples, priors, obs, model, inflation)


@renamed_keyword("kind", "model", what="the tyre-curve model")
def fit_tyre_fast(
    obs: TyreObservations,
    *,
    priors: TyrePriors | None = None,
    model: str = DEFAULT_MODEL,
    num_draws: int = LAPLACE_DRAWS,
    seed: int = 0,
    max_steps: int = 2000,
    pointwise: bool = True,
) -> TyreFit:
    """Fast path: MAP with optimistix BFGS on the unconstrained space plus a Laplace approximation.

    The MAP search runs from each start in ``MAP_STARTS`` on a long set's subset of windows
    (``search_windows``) and refines the best successful one on all windows: a long
    drive's posterior has spurious local modes. Each BFGS run works in parameters whitened by
    the Hessian at its start (for the refinement, the search's windows' Hessian scaled to all
    windows). The slips' weights (1/VIF) are then taken from the residuals at
    that mode, and the weighted posterior's mode is found by one BFGS run from the first mode
    in the refinement's coordinates (the search's basin kept; no second search). Draws come
    from the Gaussian N(mode, H⁻¹) there on the unconstrained space, mapped through the
    model's constraints.
    Convergence: the optimiser reports success within ``max_steps`` and H is positive definite.
    The solver, Hessian and draws are compiled once per data shape (padded bucket, number of
    drives, surfaces): new data of the same shape reuse them.
    """
    priors = TyrePriors() if priors is None else priors
    check_model(model)
    key_draw, key_ppc = jax.random.split(jax.random.PRNGKey(seed))
    core = _laplace_core(_priors_key(priors), model, _obs_key(obs), num_draws, max_steps)
    first, weighted, inflation = _first_pass(core, obs, model)
    mode, result = _second_pass(core, first, obs, weighted)
    obs = weighted
    min_eig, _, draws = core.laplace(mode, obs, key_draw)
    positive_definite = bool(float(min_eig) > 0)
    samples = {k: np.asarray(v) for k, v in draws.items()}
    idata = _to_inference_data(samples, 1, obs, model, key_ppc, pointwise=pointwise)
    diagnostics = _scalar_diagnostics(
        idata,
        "fast",
        optimiser_result=optimiser_outcome(result),
        problems=() if positive_definite else ("Hessian at the mode is not positive definite",),
    )
    return _tyre_fit(idata, diagnostics, samples, priors, obs, model, inflation)


@renamed_keyword("kind", "model", what="the tyre-curve model")
def fit_tyre(
    obs: TyreObservations,
    method: str = "nuts",
    *,
    priors: TyrePriors | None = None,
    model: str = DEFAULT_MODEL,
    seed: int = 0,
    num_chains: int = 4,
    num_warmup: int = 300,
    num_samples: int = 1000,
    num_draws: int = LAPLACE_DRAWS,
    max_steps: int = 2000,
    pointwise: bool = True,
) -> TyreFit:
    """Fit the per-tyre model with ``method="nuts"`` or ``"fast"`` (MAP + Laplace).

    Parameters
    ----------
    obs : TyreObservations
        Windowed observations (:func:`~tyrebayes.inference.tyre.data.stack_drives`).
    method : {"nuts", "fast", "laplace"}
        Full NUTS (:func:`fit_tyre_nuts`) or MAP + Laplace (:func:`fit_tyre_fast`; ``"laplace"``
        is the same fit, recorded as ``"fast"``):
        :data:`~tyrebayes.inference.diagnostics.FIT_METHODS`.
    priors, model, seed
        Priors (default :class:`TyrePriors`), tyre-curve model, randomness: both methods.
    num_chains, num_warmup, num_samples
        NUTS settings (ignored by the fast path). Four chains here, two in the other fitters:
        :data:`~tyrebayes.inference.diagnostics.FIT_METHODS` says why.
    num_draws, max_steps
        Fast-path settings: Laplace draws and BFGS steps (ignored by NUTS).
    pointwise : bool
        Keep the per-window log-likelihood and posterior predictive groups (200 draws × windows
        each, most of a long fit's file). False leaves them out;
        :func:`~.predictive.with_pointwise` recomputes them from the fit when wanted.

    Returns
    -------
    TyreFit
        Its ``diagnostics`` say whether it converged (the ``tyrebayes fit-tyre`` command exits 3
        when not); ``.fit`` is the one result type, ``.save(path)`` writes it.

    Examples
    --------
    >>> fit = fit_tyre(obs, method="fast")  # doctest: +SKIP
    >>> fit.summary()["c_xr"]["mean"]  # doctest: +SKIP

    Raises
    ------
    ValueError
        An unknown ``method``, or observations in single precision: slips of ~1e-3 with noise
        of ~1e-4 need float64 (``jax.config.update("jax_enable_x64", True)`` before they are
        made), and a single-precision fit could only end as not converged.
    """
    if obs.slip.dtype != jnp.float64:
        raise ValueError(
            "tyre fit: expected float64 observations (jax.config.update('jax_enable_x64', "
            f"True) before stacking them), got {obs.slip.dtype}"
        )
    if method == "nuts":
        return fit_tyre_nuts(
            obs,
            priors=priors,
            model=model,
            num_chains=num_chains,
            num_warmup=num_warmup,
            num_samples=num_samples,
            seed=seed,
            pointwise=pointwise,
        )
    if method in LAPLACE_METHODS:
        return fit_tyre_fast(
            obs,
            priors=priors,
            model=model,
            num_draws=num_draws,
            seed=seed,
            max_steps=max_steps,
            pointwise=pointwise,
        )
    raise ValueError(f"fit method: expected 'nuts', 'fast' or 'laplace', got {method!r}")
