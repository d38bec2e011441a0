"""Fitting the per-tyre model: full NUTS or a fast MAP + Laplace path, one result type.

Both return a :class:`TyreFit` whose ``idata`` is ArviZ data (a ``DataTree``) with posterior,
observed data, log-likelihood and posterior predictive groups, and whose ``diagnostics`` say
whether the fit can be trusted. A fit that did not converge says so (``converged=False``); it is
returned as data, never raised and never hidden.
"""

from __future__ import annotations

import dataclasses
import functools
import json
from functools import partial
from pathlib import Path

import arviz_base as azb
import jax
import jax.numpy as jnp
import numpy as np
import numpyro
import numpyro.distributions as dist
import optimistix as optx
import xarray as xr
from jax.flatten_util import ravel_pytree
from numpyro import handlers
from numpyro.distributions import constraints
from numpyro.distributions.transforms import biject_to
from numpyro.infer import MCMC, NUTS, init_to_median
from numpyro.infer.util import constrain_fn, initialize_model, potential_energy

from .adequacy import Adequacy, assess_adequacy
from .result import Diagnostics, Fit, Provenance, diagnose
from .summary import summarize
from .tyre_data import TyreObservations
from .tyre_model import (
    DEFAULT_KIND,
    TyrePriors,
    check_kind,
    curve_slip,
    tyre_model,
    window_likelihood,
)
from .window_correlation import slip_weights

# μ_max counts as observed on a surface only where the drive reached the limit (ABS windows) and
# the posterior sd of log μ_max is below half the prior sd. Without ABS windows the curvature of
# the linear region narrows μ_max only through the assumed brush shape, which real tyres do not
# follow closely enough to call that an observation of the peak.
MU_OBSERVED_CONTRACTION = 0.5
# Posterior predictive draws kept (memory: draws × windows per observed site).
MAX_PREDICTIVE_DRAWS = 200
# Laplace draws of the fast path (NUTS compiles the same Laplace core for its whitening).
LAPLACE_DRAWS = 2000


def FitDiagnostics(  # noqa: N802 -- the name the fast path and older callers construct
    *,
    method: str,
    r_hat_max: float,
    ess_min: float,
    divergences: int,
    optimiser_result: str,
    converged: bool,
    reason: str = "",
) -> Diagnostics:
    """A :class:`~tyrebayes.inference.result.Diagnostics` from a fitter that judged itself.

    The MAP + Laplace path decides convergence from its optimiser and Hessian (no chains to
    compare); this builds the one diagnostics type from that verdict. NUTS fits are judged by
    :func:`~tyrebayes.inference.result.diagnose` instead.
    """
    draws = float(ess_min)
    return Diagnostics(
        method=method,
        n_chains=1,
        n_draws=int(draws) if np.isfinite(draws) else 0,
        r_hat_max=float(r_hat_max),
        ess_bulk_min=draws,
        ess_tail_min=draws,
        divergences=int(divergences),
        optimiser_result=optimiser_result,
        converged=bool(converged),
        reasons=tuple(r for r in reason.split("; ") if r),
    )


@dataclasses.dataclass(frozen=True)
class TyreFit:
    """Result of :func:`fit_tyre`: a :class:`~tyrebayes.inference.result.Fit` of kind "tyre".

    Attributes
    ----------
    idata : xarray.DataTree
        ArviZ data: posterior (``c_xr``, ``c_x``, ``mu_max``, ``slip_offset``, ...), observed
        data, log-likelihood, posterior predictive, constant data (``at_limit``).
    diagnostics : Diagnostics
        Convergence under :data:`~tyrebayes.inference.result.POLICY` and model adequacy.
    mu_observed : dict[str, bool]
        Per surface: did the data reach the nonlinear region (posterior contraction of μ_max)?
    surfaces : tuple of str
    n_samples_used : int
        Number of windows that entered the likelihood.
    kind : str
        ``"magic"``, ``"shaped"``, ``"brush"`` or ``"linear"``.
    slip_variance_inflation : tuple of float
        Per drive, the variance inflation of the slip errors by their correlation between
        windows; each window's slip counted 1/this in the fit (:mod:`.window_correlation`).
    adequacy : Adequacy
        Whether the fitted model describes the drive (:mod:`.adequacy`), with the statistics of
        its checks; a converged fit can be inadequate, and then its intervals are not to be
        trusted either. ``diagnostics.adequate`` carries its verdict and reasons.
    force_range : float
        The 90th percentile of |ρ_x| over the slip windows [-]: the range of force the drive used.
    secant_stiffness : ndarray
        Posterior draws of the secant slope ρ/σ of the fitted curve at ``force_range`` [-], on
        the first surface at the drives' mean tyre temperature: what the drive measures directly.
        C_x, the slope at zero, is that secant extrapolated through the curve's shape.
    provenance : Provenance, optional
        Method, model, inputs and settings (default: method and model only).
    """

    idata: xr.DataTree
    diagnostics: Diagnostics
    mu_observed: dict
    surfaces: tuple
    n_samples_used: int
    kind: str
    slip_variance_inflation: tuple
    adequacy: Adequacy
    force_range: float
    secant_stiffness: np.ndarray
    provenance: Provenance | None = None

    @property
    def converged(self) -> bool:
        return bool(self.diagnostics.converged)

    @property
    def fit(self) -> Fit:
        """This fit in the one result type; its ``data.attrs`` carry the tyre-specific fields."""
        data = self.idata.copy()
        data.attrs.update(
            {
                "mu_observed": json.dumps({s: bool(v) for s, v in self.mu_observed.items()}),
                "surfaces": json.dumps(list(self.surfaces)),
                "n_samples_used": int(self.n_samples_used),
                "tyre_model": self.kind,
                "slip_variance_inflation": json.dumps(
                    [float(x) for x in self.slip_variance_inflation]
                ),
                "adequacy": json.dumps(self.adequacy.as_dict()),
                "force_range": float(self.force_range),
                "secant_stiffness": json.dumps([float(x) for x in self.secant_stiffness]),
            }
        )
        prov = self.provenance or Provenance(method=self.diagnostics.method, model=self.kind)
        return Fit(data=data, diagnostics=self.diagnostics, kind="tyre", provenance=prov)

    @classmethod
    def from_fit(cls, fit: Fit) -> TyreFit:
        """The tyre fit a :class:`~tyrebayes.inference.result.Fit` of kind "tyre" holds."""
        if fit.kind != "tyre":
            raise ValueError(f"fit: expected a tyre fit, got a {fit.kind} fit")
        attrs = fit.data.attrs
        return cls(
            idata=fit.data,
            diagnostics=fit.diagnostics,
            mu_observed=fit.attr("mu_observed"),
            surfaces=tuple(fit.attr("surfaces")),
            n_samples_used=int(attrs["n_samples_used"]),
            kind=str(attrs["tyre_model"]),
            slip_variance_inflation=tuple(fit.attr("slip_variance_inflation")),
            adequacy=Adequacy.from_dict(fit.attr("adequacy")),
            force_range=float(attrs["force_range"]),
            secant_stiffness=np.asarray(fit.attr("secant_stiffness"), dtype=float),
            provenance=fit.provenance,
        )

    def save(self, path) -> Path:
        """Write the fit to netCDF (:meth:`tyrebayes.inference.result.Fit.save`)."""
        return self.fit.save(path)

    def draws(self, name: str) -> np.ndarray:
        """Posterior draws of a variable, chains and draws flattened on the first axis."""
        values = np.asarray(self.idata["posterior"][name])
        return values.reshape((-1,) + values.shape[2:])

    def summary(self) -> dict:
        """The ``fit-tyre --json`` object: c_x, c_xr, mu_max, slip_offset summaries and flags.

        ``mu_max``, ``slip_offset`` and ``force_gain`` (measured over true ρ_x: load share, IMU
        scale, body pitch) describe the first surface and drive; ``mu_max_by_surface`` lists
        every surface. ``diagnostics`` is :meth:`Diagnostics.as_dict`; ``adequate`` and
        ``adequacy_reasons`` repeat its model-adequacy verdict at the top level.
        """
        mu = self.draws("mu_max")
        return {
            "c_x": summarize(self.draws("c_x")),
            "c_xr": summarize(self.draws("c_xr")),
            "mu_max": summarize(mu[:, 0]),
            "slip_offset": summarize(self.draws("slip_offset")[:, 0]),
            "force_gain": summarize(self.draws("force_gain")[:, 0]),
            "mu_max_observed": bool(self.mu_observed[self.surfaces[0]]),
            "mu_max_by_surface": {
                s: {**summarize(mu[:, i]), "observed": bool(self.mu_observed[s])}
                for i, s in enumerate(self.surfaces)
            },
            "converged": self.converged,
            "adequate": bool(self.diagnostics.adequate),
            "adequacy_reasons": list(self.diagnostics.adequacy_reasons),
            "diagnostics": self.diagnostics.as_dict(),
            "method": self.diagnostics.method,
            "model": self.kind,
            "n_samples_used": self.n_samples_used,
            "slip_variance_inflation": [float(x) for x in self.slip_variance_inflation],
            "n_abs_windows": int(np.asarray(self.idata["constant_data"]["at_limit"]).sum()),
            "noise_scales": {
                "slip": float(np.mean(self.draws("slip_noise_scale"))),
                "force": float(np.mean(self.draws("rho_noise_scale"))),
            },
            "identified": {
                "force_range": self.force_range,
                "secant_stiffness": summarize(self.secant_stiffness),
            },
        }


def _mu_observed(fit_draws: np.ndarray, priors: TyrePriors, obs: TyreObservations) -> dict:
    log_sd = np.std(np.log(fit_draws), axis=0)
    contraction = 1.0 - log_sd / np.asarray(priors.mu_log_sd(obs.surfaces))
    at_limit = np.asarray(obs.mask & obs.at_limit)
    surface = np.asarray(obs.surface_index)
    return {
        s: bool(at_limit[surface == i].any() and contraction[i] >= MU_OBSERVED_CONTRACTION)
        for i, s in enumerate(obs.surfaces)
    }


def _tyre_fit(
    idata, diagnostics, samples: dict, priors, obs: TyreObservations, kind: str, inflation
) -> TyreFit:
    """The result both fitting paths return."""
    slip_window = np.asarray(obs.mask & ~obs.at_limit)
    rho = np.asarray(obs.rho)[slip_window]
    rho = rho[np.isfinite(rho)]
    force_range = float(np.quantile(np.abs(rho), 0.9)) if rho.size else 0.0
    adequacy = _adequacy(obs, samples, kind, priors)
    return TyreFit(
        idata=idata,
        diagnostics=diagnostics.with_adequacy(adequacy.reasons),
        mu_observed=_mu_observed(samples["mu_max"], priors, obs),
        surfaces=obs.surfaces,
        n_samples_used=obs.n_used,
        kind=kind,
        slip_variance_inflation=tuple(float(x) for x in inflation),
        adequacy=adequacy,
        force_range=force_range,
        secant_stiffness=_secant_stiffness(samples, kind, force_range),
    )


def _secant_stiffness(samples: dict, kind: str, force: float) -> np.ndarray:
    """Draws of ρ/σ(ρ) of the fitted curve at ``force`` (first surface, C_x at the mean T)."""
    if force <= 0:
        return np.asarray(samples["c_x"], float)
    mu = np.asarray(samples["mu_max"])[:, 0]
    force = np.minimum(force, 0.999 * mu)
    slip = np.asarray(curve_slip(kind, force, samples["c_x"], mu, samples))
    with np.errstate(invalid="ignore", divide="ignore"):
        return force / slip


def _adequacy(obs: TyreObservations, samples: dict, kind: str, priors: TyrePriors) -> Adequacy:
    """:func:`.adequacy.assess_adequacy` at the posterior mean (slip windows, time order)."""
    point = {k: jnp.mean(jnp.asarray(v), axis=0) for k, v in samples.items()}
    lik = window_likelihood(point, obs, kind)
    slip_window = np.asarray(obs.mask & ~obs.at_limit)
    z = np.asarray((obs.slip - lik.slip_loc - lik.block_offset) / lik.slip_scale)[slip_window]
    shape_sds = {}
    if kind == "magic":
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
    offsets = np.asarray(lik.block_offset)[slip_window]
    # Blocks are numbered in time order within each drive (stack_drives).
    per_drive = []
    for d in range(obs.n_drives):
        _, first = np.unique(blocks[drives == d], return_index=True)
        per_drive.append(offsets[drives == d][first])
    return assess_adequacy(
        z,
        np.asarray(obs.rho)[slip_window],
        drives,
        obs.n_drives,
        shape_prior_sds=shape_sds,
        block_offsets=tuple(per_drive),
    )


def _weighted_by_correlation(obs: TyreObservations, draws: dict, kind: str):
    """``obs`` with each drive's slip weight 1/VIF from the residuals at the draws' mean.

    Returns ``(obs, inflation)``. The weights change the posterior's width, not its centre
    (to first order), so a first fit with unit weights gives residuals good enough for them.
    """
    point = {k: jnp.mean(jnp.asarray(v), axis=0) for k, v in draws.items()}
    lik = window_likelihood(point, obs, kind)
    z = np.asarray((obs.slip - lik.slip_loc - lik.block_offset) / lik.slip_scale)
    slip_window = np.asarray(obs.mask & ~obs.at_limit)
    weights, inflation = slip_weights(z, slip_window, np.asarray(obs.drive_index), obs.n_drives)
    weighted = dataclasses.replace(obs, slip_weight=jnp.asarray(weights, dtype=obs.slip.dtype))
    return weighted, inflation


def _thin_index(total: int, n: int) -> np.ndarray:
    return np.linspace(0, total - 1, min(n, total)).astype(int)


def _observed(obs: TyreObservations) -> dict:
    mask = np.asarray(obs.mask)
    return {"slip_obs": np.asarray(obs.slip)[mask], "rho_obs": np.asarray(obs.rho)[mask]}


def _priors_key(priors: TyrePriors) -> tuple:
    return tuple(float(x) for x in jax.tree_util.tree_leaves(priors))


def _obs_key(obs: TyreObservations) -> tuple:
    return (obs.slip.shape[0], obs.n_drives, obs.surfaces)


@functools.lru_cache(maxsize=16)
def _predictive_core(kind: str, obs_key: tuple, n_draws: int):
    """Jitted per-window log-likelihood and posterior predictive draws (compiled once per shape).

    ``core(samples, obs, key)`` gives ``(loglik, ppc)``, each ``{"slip_obs", "rho_obs"}`` of
    shape (draws, windows). Both come from :func:`window_likelihood`, evaluated once per draw:
    the Normal log-densities of the measured slip and force, and draws from those Normals. The
    slip of an ABS window is not observed: its log-likelihood is 0, as in the model's mask.
    (The true slip is integrated out, so the predictive force is not conditioned on the measured
    slip; slip_obs is drawn around the slip of the measured force.)
    """
    del obs_key, n_draws  # part of the cache key: one compilation per shape

    def one_draw(params, obs, key):
        lik = window_likelihood(params, obs, kind)
        slip_observed = obs.mask & ~obs.at_limit
        # Given the window's block offset (its conditional mean): the per-window terms leave
        # the blocks' shared offsets out, as the model's marginal does not.
        slip_loc = lik.slip_loc + lik.block_offset
        slip_ll = dist.Normal(slip_loc, lik.slip_scale).log_prob(obs.slip)
        loglik = {
            "slip_obs": jnp.where(slip_observed, slip_ll, 0.0),
            "rho_obs": dist.Normal(lik.rho_loc, lik.rho_scale).log_prob(obs.rho),
        }
        key_slip, key_rho = jax.random.split(key)

        def draw(k, loc, scale):
            return loc + scale * jax.random.normal(k, loc.shape, dtype=loc.dtype)

        ppc = {
            "slip_obs": draw(key_slip, slip_loc, lik.slip_scale),
            "rho_obs": draw(key_rho, lik.rho_loc, lik.rho_scale),
        }
        return loglik, ppc

    @jax.jit
    def core(samples, obs, key):
        keys = jax.random.split(key, next(iter(samples.values())).shape[0])
        # A few draws at a time rather than all at once: the intermediates of 200 draws of a
        # long drive do not fit in cache (ten one-hour drives: 1.2 s against 2.6 s).
        return jax.lax.map(
            lambda args: one_draw(args[0], obs, args[1]), (samples, keys), batch_size=8
        )

    return core


def _to_inference_data(
    samples: dict, n_chains: int, obs: TyreObservations, kind: str, key, sample_stats=None
) -> xr.DataTree:
    """ArviZ data with posterior, log-likelihood, posterior predictive, observed and constant data.

    Log-likelihood and posterior predictive use at most :data:`MAX_PREDICTIVE_DRAWS` draws per
    fit (evenly thinned within each chain), stored as float32: per-window arrays of a long drive
    would otherwise dominate memory.
    """
    mask = np.asarray(obs.mask)

    def by_chain(x):
        x = np.asarray(x)
        return x.reshape((n_chains, -1) + x.shape[1:])

    posterior = {k: by_chain(v) for k, v in samples.items()}
    per_chain = next(iter(posterior.values())).shape[1]
    keep = _thin_index(per_chain, max(1, MAX_PREDICTIVE_DRAWS // n_chains))
    # Single precision, like the stored result (on ten one-hour drives it took 6.7 s against
    # 7.7 s in float64, measured with numpyro's log_likelihood and Predictive before
    # window_likelihood replaced them).
    thinned = {
        k: jnp.asarray(v[:, keep].reshape((-1,) + v.shape[2:]), dtype=jnp.float32)
        for k, v in posterior.items()
    }
    core = _predictive_core(kind, _obs_key(obs), len(keep) * n_chains)
    loglik, ppc = core(thinned, _single_precision(obs), key)

    used = int(mask.sum())
    # stack_drives pads at the end: then the used windows are a view, not a copy of the array.
    windows = slice(0, used) if mask[:used].all() else mask

    def per_window(x):
        # Computed in float32 (values beyond its range, a failed fit's, are ±inf).
        x = np.asarray(x, dtype=np.float32)[:, windows]
        return x.reshape((n_chains, len(keep)) + x.shape[1:])

    loglik = {k: per_window(v) for k, v in loglik.items()}
    ppc = {k: per_window(v) for k, v in ppc.items()}
    dims = {"slip_obs": ["window"], "rho_obs": ["window"], "mu_max": ["surface"]}
    coords = {"surface": list(obs.surfaces), "window": np.arange(used)}
    thin_coords = {**coords, "draw": keep}
    at_limit = np.asarray(obs.at_limit)[mask]
    groups = {"posterior": posterior, "observed_data": _observed(obs)}
    if sample_stats is not None:
        groups["sample_stats"] = sample_stats
    idata = azb.from_dict(groups, dims=dims, coords=coords)
    # The thinned groups have their own draw coordinate, so they are built apart and attached.
    extra = azb.from_dict(
        {"log_likelihood": loglik, "posterior_predictive": ppc}, dims=dims, coords=thin_coords
    )
    constant = azb.from_dict(
        {"constant_data": {"at_limit": at_limit}}, dims={"at_limit": ["window"]}, coords=coords
    )
    for name in ("log_likelihood", "posterior_predictive"):
        idata[name] = extra[name]
    idata["constant_data"] = constant["constant_data"]
    return idata


def _scalar_diagnostics(idata: xr.DataTree, method: str = "nuts") -> Diagnostics:
    """:func:`~tyrebayes.inference.result.diagnose` over every parameter but C_x.

    C_x is C_xr times a function of the temperature sensitivity: a deterministic function of
    checked parameters.
    """
    names = [v for v in idata["posterior"].data_vars if v not in ("c_x",)]
    return diagnose(idata, method=method, var_names=names)


def fit_tyre_nuts(
    obs: TyreObservations,
    *,
    priors: TyrePriors | None = None,
    kind: str = DEFAULT_KIND,
    num_chains: int = 4,
    num_warmup: int = 300,
    num_samples: int = 1000,
    seed: int = 0,
    progress_bar: bool = False,
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
    check_kind(kind)
    key_laplace, key_init, key_run, key_ppc = jax.random.split(jax.random.PRNGKey(seed), 4)
    core, flat0 = _laplace_core(_priors_key(priors), kind, _obs_key(obs), LAPLACE_DRAWS, 2000)
    *_, first_draws = core(flat0, obs, key_laplace)
    obs, inflation = _weighted_by_correlation(obs, first_draws, kind)
    mode, _, _, scale, _ = core(flat0, obs, key_laplace)
    runner = _nuts_runner(
        _priors_key(priors), kind, _obs_key(obs), num_chains, num_warmup, num_samples
    )
    u_init = 2.0 * jax.random.normal(key_init, (num_chains, flat0.shape[0]), dtype=flat0.dtype)
    samples, diverging = runner(key_run, obs, mode, scale, u_init, progress_bar)
    samples = {k: np.asarray(v) for k, v in samples.items()}
    diverging = np.asarray(diverging).reshape(num_chains, -1)
    idata = _to_inference_data(
        samples, num_chains, obs, kind, key_ppc, sample_stats={"diverging": diverging}
    )
    diagnostics = _scalar_diagnostics(idata)
    return _tyre_fit(idata, diagnostics, samples, priors, obs, kind, inflation)


def _whitened_model(obs, mode, scale, *, model, unravel):
    """The model's posterior over u, with unconstrained parameters z = mode + scale @ u.

    The model itself is evaluated in single precision (``obs`` comes in float32, z is cast): its
    gradient costs 2.6x less than in float64 on this CPU (one-hour drive, 9,216 padded windows:
    0.79 vs 2.05 ms), and rounding changes the energy by ~1e-3 nats, far below the energy
    errors of a leapfrog trajectory that NUTS accepts. u, the mass matrix and the tree building
    stay in float64 (numpyro mixes the two if they do not), and the mode and its Hessian, where
    differences of 1e-8 matter, come from the float64 fast path.
    """
    u = numpyro.sample(
        "u", dist.ImproperUniform(constraints.real, (), event_shape=(mode.shape[0],))
    )
    params = jax.tree.map(lambda z: z.astype(jnp.float32), unravel(mode + scale @ u))
    with handlers.block():  # the inner model's sites stay out of this trace
        energy = potential_energy(model, (obs,), {}, params)
    numpyro.factor("log_density", -energy.astype(mode.dtype))


def _single_precision(obs: TyreObservations) -> TyreObservations:
    """``obs`` with its floating-point fields in float32 (see :func:`_whitened_model`)."""
    return jax.tree.map(
        lambda x: x.astype(jnp.float32) if jnp.issubdtype(x.dtype, jnp.floating) else x, obs
    )


def _model_layout(priors_key: tuple, kind: str, obs_key: tuple):
    """The model for one data shape, a template of that shape and its median parameters.

    Returns ``(model, template, params)``; ``params`` are unconstrained, keyed by site, and fix
    the flat layout (``ravel_pytree``) that the Laplace core and the NUTS runner share.
    """
    model = partial(tyre_model, priors=TyrePriors(*priors_key), kind=kind)
    template = _template_observations(*obs_key)
    # init_to_median draws a batch of prior samples; numpyro broadcasts it by rank promotion.
    with jax.numpy_rank_promotion("allow"):
        init = initialize_model(
            jax.random.PRNGKey(0), model, model_args=(template,), init_strategy=init_to_median
        )
    return model, template, init.param_info.z


def _chains_per_run(num_chains: int) -> int:
    """Chains run side by side: one per CPU device, in equal groups (else one at a time).

    JAX sees one CPU device unless told otherwise before it starts
    (``numpyro.set_host_device_count``; the ``tyrebayes`` command sets one device per core).
    """
    devices = min(num_chains, jax.local_device_count())
    while num_chains % devices:
        devices -= 1
    return devices


@functools.lru_cache(maxsize=8)
def _nuts_runner(
    priors_key: tuple, kind: str, obs_key: tuple, num_chains: int, num_warmup: int, num_samples
):
    """NUTS on the whitened model, one MCMC object per shape so its compiled kernel is reused.

    Returns ``run(key, obs, mode, scale, u_init, progress_bar)`` giving the constrained draws
    (with deterministic sites), chains stacked on the first axis, and the divergence flags.
    """
    model, _, params = _model_layout(priors_key, kind, obs_key)
    _, unravel = ravel_pytree(params)
    kernel = NUTS(
        partial(_whitened_model, model=model, unravel=unravel),
        target_accept_prob=0.9,
        dense_mass=True,
        max_tree_depth=8,
    )
    per_run = _chains_per_run(num_chains)
    mcmc = MCMC(
        kernel,
        num_warmup=num_warmup,
        num_samples=num_samples,
        num_chains=per_run,
        # One chain per CPU device at a time, never vectorised: a vectorised step costs more
        # than four single-chain steps on one core (measured 19.5 vs 4 x 4.6 ms per gradient,
        # one-hour drive padded to 16,384 windows, x64) and waits for the longest trajectory.
        chain_method="parallel" if per_run > 1 else "sequential",
        progress_bar=False,
        jit_model_args=True,
    )

    @jax.jit
    def constrain(z, obs):
        return jax.vmap(
            lambda f: constrain_fn(model, (obs,), {}, unravel(f), return_deterministic=True)
        )(z)

    def run(key, obs, mode, scale, u_init, progress_bar):
        mcmc.progress_bar = progress_bar
        obs_single = _single_precision(obs)
        u, diverging = [], []
        for group, run_key in enumerate(jax.random.split(key, num_chains // per_run)):
            chains = slice(group * per_run, (group + 1) * per_run)
            mcmc.run(
                run_key,
                obs_single,
                mode,
                scale,
                init_params={"u": u_init[chains]},
                extra_fields=("diverging",),
            )
            u.append(mcmc.get_samples(group_by_chain=True)["u"])
            diverging.append(mcmc.get_extra_fields(group_by_chain=True)["diverging"])
        u = jnp.concatenate(u).reshape(-1, mode.shape[0])
        z = mode[None, :] + u @ scale.T
        return constrain(z, obs), jnp.concatenate(diverging).reshape(-1)

    return run


@functools.lru_cache(maxsize=16)
def _laplace_core(priors_key: tuple, kind: str, obs_key: tuple, num_draws: int, max_steps: int):
    """Jitted MAP + Hessian + Laplace draws for one data shape (compiled once per shape).

    Returns ``(core, flat0)``: ``core(flat0, obs, key)`` gives the mode, the optimiser result,
    the smallest Hessian eigenvalue, the scale S with S S' = H⁻¹ (eigenvalues floored) and the
    constrained draws (with deterministic sites).
    """
    priors = TyrePriors(*priors_key)
    model, template, params = _model_layout(priors_key, kind, obs_key)
    flat0, unravel = ravel_pytree(params)
    hessian_at = _block_hessian(model, template, params)

    def negative_log_posterior(flat, obs):
        return potential_energy(model, (obs,), {}, unravel(flat))

    def minimise_from(flat_start, obs):
        # BFGS starts from the identity, but the posterior's scales differ by orders of magnitude
        # (a slip offset known to 1e-5, a force level to 1e-2) and its parameters are
        # correlated (C_xr with μ_max and the slip offsets). It works in y with
        # x = start + W y, W = V |Λ|^(-1/2) from the Hessian at the start (eigenvalues in
        # absolute value, floored: far from the mode H need not be positive definite), so that
        # its first step is a Newton step. Steps per BFGS run, search (four starts) and
        # refinement, with the data-driven starts of _start (brush model, measured before the
        # shaped model became the default): one one-hour drive 45-56 and 40
        # (diagonal rescaling x = start + y/√|H_ii|: 69-74 and 84); ten stacked one-hour drives
        # 32-53 and 49 (79-83 and 103). Without any rescaling a one-hour drive took 240-360.
        hessian = hessian_at(lambda f: negative_log_posterior(f, obs), flat_start)
        finite = jnp.all(jnp.isfinite(hessian))
        eigenvalues, vectors = jnp.linalg.eigh(jnp.where(finite, hessian, jnp.eye(len(flat_start))))
        whiten = vectors / jnp.sqrt(jnp.maximum(jnp.abs(eigenvalues), 1.0))[None, :]

        def rescaled(y, obs):
            return negative_log_posterior(flat_start + whiten @ y, obs)

        solver = optx.BFGS(rtol=1e-8, atol=1e-8)
        sol = optx.minimise(
            rescaled, solver, jnp.zeros_like(flat_start), args=obs, max_steps=max_steps, throw=False
        )
        return flat_start + whiten @ sol.value, sol.result

    stride = _search_stride(obs_key[0])

    @jax.jit
    def core(flat_init, obs, key):
        # Several starts on every stride-th window find the basin; the best successful one is
        # refined on all windows (module comment at MAP_STARTS).
        coarse = _every_nth_window(obs, stride)
        starts = jax.vmap(lambda c, m: _start(flat_init, unravel, coarse, priors, c, m))(
            *map(jnp.asarray, zip(*MAP_STARTS, strict=True))
        )
        values, results = jax.vmap(minimise_from, (0, None))(starts, coarse)
        energies = jax.vmap(negative_log_posterior, (0, None))(values, coarse)
        ok = (results == optx.RESULTS.successful) & jnp.isfinite(energies)
        best = jnp.argmin(jnp.where(ok, energies, jnp.inf))
        best = jnp.where(ok.any(), best, jnp.argmin(jnp.nan_to_num(energies, nan=jnp.inf)))
        mode, result = values[best], jax.tree.map(lambda r: r[best], results)
        if stride > 1:
            mode, result = minimise_from(mode, obs)
        hessian = hessian_at(lambda f: negative_log_posterior(f, obs), mode)
        eigenvalues, vectors = jnp.linalg.eigh(hessian)
        finite = jnp.all(jnp.isfinite(hessian))
        # A non-positive-definite Hessian still gives draws (eigenvalues floored) so that the
        # result can be inspected; it is flagged as not converged.
        floored = jnp.where(finite, jnp.maximum(eigenvalues, 1e-6), 1.0)
        vectors = jnp.where(finite, vectors, jnp.eye(len(flat_init)))
        # z = mode + S u with S S' = H⁻¹: the Laplace draws, and NUTS's whitening.
        scale = vectors / jnp.sqrt(floored)[None, :]
        eps = jax.random.normal(key, (num_draws, len(flat_init)), dtype=mode.dtype)
        z = mode[None, :] + eps @ scale.T
        draws = jax.vmap(
            lambda f: constrain_fn(model, (obs,), {}, unravel(f), return_deterministic=True)
        )(z)
        min_eig = jnp.where(finite, eigenvalues.min(), -jnp.inf)
        return mode, result, min_eig, scale, draws

    return core, flat0


# Windows the multi-start search reads at most (about a quarter of a one-hour 100 Hz drive).
SEARCH_WINDOWS = 2304


def _search_stride(size: int) -> int:
    """Every how many windows the multi-start search reads: about :data:`SEARCH_WINDOWS` of them.

    The search only has to find the right basin; the refinement on all windows finds the mode.
    On one full one-hour drive the spurious mode lay ~3,000 nats below the right one, so a
    quarter of the windows should still keep a gap of several hundred (an estimate; the
    spurious-mode regression test and the recovery benchmark pass with it). A fixed budget keeps
    the search's cost from growing with the data: ten one-hour drives pay one search, not ten.
    Short drives keep every window.
    """
    return max(1, size // SEARCH_WINDOWS)


def _every_nth_window(obs: TyreObservations, n: int) -> TyreObservations:
    """The observations of every n-th window (padding stays at the end, so it stays padding)."""
    if n == 1:
        return obs
    arrays = {
        f.name: getattr(obs, f.name)[::n]
        for f in dataclasses.fields(obs)
        if not f.metadata.get("static")
    }
    return dataclasses.replace(obs, **arrays)


def _drive_moments(obs: TyreObservations):
    """Per-drive means of slip and force and their centred second moments (slip windows only).

    Returns ``(slip_mean, rho_mean, rho_var, slip_rho_cov, slip_var)``, each of shape
    ``(n_drives,)``; a drive without slip windows gets zeros.
    """
    weight = (obs.mask & ~obs.at_limit).astype(obs.slip.dtype)
    count = jnp.maximum(jax.ops.segment_sum(weight, obs.drive_index, obs.n_drives), 1.0)

    def mean(x):
        return jax.ops.segment_sum(weight * x, obs.drive_index, obs.n_drives) / count

    slip_mean, rho_mean = mean(obs.slip), mean(obs.rho)
    slip = obs.slip - slip_mean[obs.drive_index]
    rho = obs.rho - rho_mean[obs.drive_index]
    return slip_mean, rho_mean, mean(rho**2), mean(slip * rho), mean(slip**2)


def _stiffness_start(moments, priors: TyrePriors) -> jax.Array:
    """A data scale for the MAP starts' C_xr: least-squares slope of force on slip within drives.

    ``moments`` is what :func:`_drive_moments` returns.

    Attenuated by the slip noise (below the truth), cheap, and on the data's scale where the
    prior median (35) may be far from it (``MAP_STARTS``).
    """
    *_, slip_rho_cov, slip_var = moments
    slope = jnp.sum(slip_rho_cov) / jnp.sum(slip_var)
    usable = jnp.isfinite(slope) & (slope > 0)
    return jnp.clip(jnp.where(usable, slope, priors.c_xr_median), 5.0, 200.0)


# Starts of the MAP search as (C_xr factor on the within-drive least-squares slope, μ_max
# quantile in prior sds). The posterior of one long drive has spurious local modes: μ_max below
# the largest measured forces, where the inverse maps them to the peak slip, and C_x up to twice
# the truth (one-hour drives, brush truth: from the prior median alone 14 of 50 drives without
# ABS and 2 of 50 with it ended there, thousands of nats below the right mode; no single start
# tried avoided them all). The slope is attenuated by slip noise (~0.75 of the truth), hence 1.35.
MAP_STARTS = ((1.0, 0.0), (1.35, 0.0), (1.0, 2.0), (1.35, 2.0))


def _start(flat_init, unravel, obs, priors, stiffness_factor, mu_sds):
    """One starting point of the MAP search (unconstrained, flat).

    C_xr and μ_max as ``MAP_STARTS`` says; each drive's force level and spread from its measured
    forces and its slip offset from its mean slip and force at that C_xr (so that BFGS does not
    spend hundreds of steps walking forty per-drive parameters in from the prior medians); the
    rest at ``flat_init``.
    """
    start = unravel(flat_init)
    positive = biject_to(constraints.positive).inv
    moments = _drive_moments(obs)
    c_xr = stiffness_factor * _stiffness_start(moments, priors)
    start["c_xr"] = positive(c_xr)
    mu = priors.mu_median(obs.surfaces) * jnp.exp(mu_sds * priors.mu_log_sd(obs.surfaces))
    start["mu_max"] = positive(mu)
    slip_mean, rho_mean, rho_var, *_ = moments
    start["force_level"] = rho_mean
    start["force_spread"] = positive(jnp.sqrt(jnp.maximum(rho_var, 1e-6)))
    start["slip_offset"] = jnp.clip(slip_mean - rho_mean / c_xr, -0.02, 0.02)
    return ravel_pytree(start)[0]


def _block_hessian(model, template: TyreObservations, params: dict):
    """Hessian of a function of the flat parameters, using that drives do not interact.

    The per-drive parameters of one drive meet the windows of that drive only, so the Hessian
    is block-arrow shaped: dense over the global parameters, one block per drive, zero between
    drives. One Hessian-vector product per global parameter gives those columns exactly; one
    product per per-drive *site*, pushing that site in every drive at once, gives each drive's
    block (rows of other drives are zero there), and the global rows of those columns follow
    by symmetry. That is n_global + n_drive_sites products instead of one per parameter: a
    ten-drive fit no longer pays ten times more products on ten times more data.

    Returns ``hessian_at(f, x)`` for ``f`` of the flat vector laid out like ``params``.
    """
    with jax.numpy_rank_promotion("allow"):
        trace = handlers.trace(handlers.seed(model, 0)).get_trace(template)
    drive_of = {}
    for name, value in params.items():
        site = trace[name]
        in_drive = any(f.name == "drive" for f in site["cond_indep_stack"])
        drive_of[name] = (
            np.broadcast_to(np.arange(template.n_drives), np.shape(value)).astype(float)
            if in_drive
            else np.full(np.shape(value), -1.0)
        )
        if in_drive and np.shape(value) != (template.n_drives,):
            raise ValueError(
                f"site {name!r}: expected shape ({template.n_drives},) in the drive plate, "
                f"got {np.shape(value)}"
            )
    drive = np.asarray(ravel_pytree(drive_of)[0]).astype(int)
    site_of = ravel_pytree({k: np.full(np.shape(v), i) for i, (k, v) in enumerate(params.items())})
    site = np.asarray(site_of[0]).astype(int)
    n = drive.size
    global_idx = np.flatnonzero(drive < 0)
    drive_sites = sorted({int(site[i]) for i in np.flatnonzero(drive >= 0)})
    directions = np.zeros((len(global_idx) + len(drive_sites), n))
    directions[np.arange(len(global_idx)), global_idx] = 1.0
    for k, s in enumerate(drive_sites):
        directions[len(global_idx) + k, site == s] = 1.0
    is_global_row = drive < 0

    def hessian_at(f, x):
        def hvp(v):
            return jax.jvp(jax.grad(f), (x,), (v,))[1]

        products = jax.vmap(hvp)(jnp.asarray(directions, dtype=x.dtype))  # (n_dir, n)
        h = jnp.zeros((n, n), dtype=x.dtype)
        h = h.at[:, global_idx].set(products[: len(global_idx)].T)
        for k, s in enumerate(drive_sites):
            combined = products[len(global_idx) + k]
            for c in np.flatnonzero(site == s):
                same_drive = drive == drive[c]
                column = jnp.where(same_drive, combined, 0.0)
                # Global rows of this column: by symmetry, row c of the global columns.
                column = jnp.where(is_global_row, h[c, :], column)
                h = h.at[:, c].set(column)
        return 0.5 * (h + h.T)

    return hessian_at


def _template_observations(size: int, n_drives: int, surfaces: tuple) -> TyreObservations:
    """Observations of the given shape with harmless values (for tracing only)."""
    zeros = jnp.zeros(size)
    return TyreObservations(
        slip=zeros,
        rho=zeros,
        slip_sd=jnp.ones(size),
        rho_sd=jnp.ones(size),
        temperature_c=jnp.full(size, 20.0),
        neighbour_slip=zeros,
        slip_weight=jnp.ones(size),
        imu_gain_log_sd=zeros,
        rho_score=zeros,
        rho_score_slope=zeros,
        at_limit=jnp.zeros(size, dtype=bool),
        drive_index=jnp.zeros(size, dtype=int),
        block_index=jnp.zeros(size, dtype=int),
        surface_index=jnp.zeros(size, dtype=int),
        mask=jnp.ones(size, dtype=bool),
        n_drives=n_drives,
        surfaces=surfaces,
    )


def fit_tyre_fast(
    obs: TyreObservations,
    *,
    priors: TyrePriors | None = None,
    kind: str = DEFAULT_KIND,
    num_draws: int = LAPLACE_DRAWS,
    seed: int = 0,
    max_steps: int = 2000,
) -> TyreFit:
    """Fast path: MAP with optimistix BFGS on the unconstrained space plus a Laplace approximation.

    The MAP search runs from the starts in ``MAP_STARTS`` at once (vectorised) on every
    ``_search_stride``-th window and refines the best successful one on all windows: a long
    drive's posterior has spurious local modes. Each BFGS run works in parameters whitened by
    the Hessian at its start. Draws come from the Gaussian N(mode, H⁻¹) on the unconstrained
    space, mapped through the model's constraints.
    Convergence: the optimiser reports success within ``max_steps`` and H is positive definite.
    The solver, Hessian and draws are compiled once per data shape (padded bucket, number of
    drives, surfaces): new data of the same shape reuse them.
    """
    priors = TyrePriors() if priors is None else priors
    check_kind(kind)
    key_draw, key_ppc = jax.random.split(jax.random.PRNGKey(seed))
    core, flat0 = _laplace_core(_priors_key(priors), kind, _obs_key(obs), num_draws, max_steps)
    *_, first_draws = core(flat0, obs, key_draw)
    obs, inflation = _weighted_by_correlation(obs, first_draws, kind)
    _, result, min_eig, _, draws = core(flat0, obs, key_draw)
    optimiser_ok = bool(result == optx.RESULTS.successful)
    positive_definite = bool(float(min_eig) > 0)
    problems = []
    if not optimiser_ok:
        problems.append(f"optimiser: {optx.RESULTS[result]}")
    if not positive_definite:
        problems.append("Hessian at the mode is not positive definite")
    samples = {k: np.asarray(v) for k, v in draws.items()}
    if not all(np.all(np.isfinite(v)) for v in samples.values()):
        problems.append("non-finite draws")
    idata = _to_inference_data(samples, 1, obs, kind, key_ppc)
    diagnostics = FitDiagnostics(
        method="fast",
        r_hat_max=float("nan"),
        ess_min=float(num_draws),
        divergences=0,
        optimiser_result="successful" if optimiser_ok else str(optx.RESULTS[result]),
        converged=not problems,
        reason="; ".join(problems),
    )
    return _tyre_fit(idata, diagnostics, samples, priors, obs, kind, inflation)


def fit_tyre(
    obs: TyreObservations,
    method: str = "nuts",
    *,
    priors: TyrePriors | None = None,
    kind: str = DEFAULT_KIND,
    seed: int = 0,
    num_chains: int = 4,
    num_warmup: int = 300,
    num_samples: int = 1000,
    progress_bar: bool = False,
    num_draws: int = LAPLACE_DRAWS,
    max_steps: int = 2000,
) -> TyreFit:
    """Fit the per-tyre model with ``method="nuts"`` or ``"fast"`` (MAP + Laplace).

    Parameters
    ----------
    obs : TyreObservations
        Windowed observations (:func:`~tyrebayes.inference.tyre_data.stack_drives`).
    method : {"nuts", "fast"}
        Full NUTS (:func:`fit_tyre_nuts`) or MAP + Laplace (:func:`fit_tyre_fast`).
    priors, kind, seed
        Priors (default :class:`TyrePriors`), tyre-curve model, randomness: both methods.
    num_chains, num_warmup, num_samples, progress_bar
        NUTS settings (ignored by the fast path).
    num_draws, max_steps
        Fast-path settings: Laplace draws and BFGS steps (ignored by NUTS).

    Returns
    -------
    TyreFit
        Its ``diagnostics`` say whether it converged (the ``tyrebayes fit-tyre`` command exits 3
        when not); ``.fit`` is the one result type, ``.save(path)`` writes it.

    Examples
    --------
    >>> fit = fit_tyre(obs, method="fast")  # doctest: +SKIP
    >>> fit.summary()["c_xr"]["mean"]  # doctest: +SKIP
    """
    if method == "nuts":
        return fit_tyre_nuts(
            obs,
            priors=priors,
            kind=kind,
            num_chains=num_chains,
            num_warmup=num_warmup,
            num_samples=num_samples,
            seed=seed,
            progress_bar=progress_bar,
        )
    if method == "fast":
        return fit_tyre_fast(
            obs, priors=priors, kind=kind, num_draws=num_draws, seed=seed, max_steps=max_steps
        )
    raise ValueError(f"fit method: expected 'nuts' or 'fast', got {method!r}")
