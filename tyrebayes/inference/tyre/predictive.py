"""The stored part of a per-tyre fit: per-window log-likelihood, posterior predictive, the data.

A fit keeps every window's observations (observed and constant data) and the key of its
predictive draws, so that the per-window groups are a function of the stored fit: a fit made with
``pointwise=False`` (the fleet run's, where those groups were most of a fit file's size and
their computation part of every fit's time) leaves them out and :func:`with_pointwise`
recomputes them when criticism needs them, equal to the ones a ``pointwise=True`` fit stores.
"""

from __future__ import annotations

import functools
import json

import arviz_base as azb
import jax
import jax.numpy as jnp
import numpy as np
import numpyro.distributions as dist
import xarray as xr

from ..._errors import BadInputError
from ...internal.stored_program import stored_program
from ..result import Diagnostics, Fit, diagnose
from .data import TyreObservations, bucket_size
from .model import (
    TyrePriors,
    window_likelihood,
)

# Posterior predictive draws kept (memory: draws × windows per observed site).
MAX_PREDICTIVE_DRAWS = 200
# The per-window fields of TyreObservations kept in a fit's constant data (slip and ρ are its
# observed data): with them the observations, hence the per-window groups, can be rebuilt.
WINDOW_FIELDS = (
    "at_limit",
    "temperature_c",
    "load_change",
    "drive_index",
    "block_index",
    "surface_index",
    "slip_sd",
    "rho_sd",
    "neighbour_slip",
    "slip_weight",
    "imu_gain_log_sd",
    "rho_score",
    "rho_score_slope",
)
# data.attrs key of the predictive draws' PRNG key (JSON list of its uint32 words).
_KEY_ATTR = "predictive_key"


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
def _predictive_core(model: str, obs_key: tuple, n_draws: int):
    """Jitted per-window log-likelihood and posterior predictive draws (compiled once per shape).

    ``core(samples, obs, key)`` gives ``(loglik, ppc)``, each ``{"slip_obs", "rho_obs"}`` of
    shape (draws, windows). Both come from :func:`window_likelihood`, evaluated once per draw:
    the Normal log-densities of the measured slip and force, and draws from those Normals. The
    slip of an ABS window is not observed: its log-likelihood is 0, as in the model's mask.
    (The true slip is integrated out, so the predictive force is not conditioned on the measured
    slip; slip_obs is drawn around the slip of the measured force.)
    """

    def one_draw(params, obs, key):
        lik = window_likelihood(params, obs, model)
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

    # Kept on disk once traced (a new process reads it instead of tracing the model again).
    return stored_program(core, ("tyre-predictive-core", model, obs_key, n_draws))


def _to_inference_data(
    samples: dict,
    n_chains: int,
    obs: TyreObservations,
    model: str,
    key,
    sample_stats=None,
    pointwise: bool = True,
) -> xr.DataTree:
    """ArviZ data with posterior, log-likelihood, posterior predictive, observed and constant data.

    Log-likelihood and posterior predictive use at most :data:`MAX_PREDICTIVE_DRAWS` draws per
    fit (evenly thinned within each chain), stored as float32: per-window arrays of a long drive
    would otherwise dominate memory. ``pointwise=False`` leaves those two groups out
    (:func:`with_pointwise` makes them from the rest).
    """
    mask = np.asarray(obs.mask)

    def by_chain(x):
        x = np.asarray(x)
        return x.reshape((n_chains, -1) + x.shape[1:])

    posterior = {k: by_chain(v) for k, v in samples.items()}
    coords = {"surface": list(obs.surfaces), "window": np.arange(int(mask.sum()))}
    groups = {"posterior": posterior, "observed_data": _observed(obs)}
    if sample_stats is not None:
        groups["sample_stats"] = sample_stats
    idata = azb.from_dict(groups, dims=_DIMS, coords=coords)
    # Per-window conditions and likelihood inputs: criticism scans a saved fit's residuals
    # against them, and with them the per-window groups can be recomputed.
    window_data = {name: np.asarray(getattr(obs, name))[mask] for name in WINDOW_FIELDS}
    constant = azb.from_dict(
        {"constant_data": window_data},
        dims={name: ["window"] for name in window_data},
        coords=coords,
    )
    idata["constant_data"] = constant["constant_data"]
    idata.attrs[_KEY_ATTR] = json.dumps([int(w) for w in np.asarray(key).ravel()])
    if pointwise:
        _attach_pointwise(idata, posterior, obs, model, key)
    return idata


_DIMS = {"slip_obs": ["window"], "rho_obs": ["window"], "mu_max": ["surface"]}


def _attach_pointwise(
    idata: xr.DataTree, posterior: dict, obs: TyreObservations, model: str, key
) -> None:
    """Add the log-likelihood and posterior predictive groups (thinned draws) to ``idata``."""
    mask = np.asarray(obs.mask)
    n_chains, per_chain = next(iter(posterior.values())).shape[:2]
    keep = _thin_index(per_chain, max(1, MAX_PREDICTIVE_DRAWS // n_chains))
    # Single precision, like the stored result (on ten one-hour drives it took 6.7 s against
    # 7.7 s in float64, measured with numpyro's log_likelihood and Predictive before
    # window_likelihood replaced them).
    # A failed fit's draws can lie beyond float32's range: they become ±inf, as intended.
    with np.errstate(over="ignore"):
        thinned = {
            k: jnp.asarray(v[:, keep].reshape((-1,) + v.shape[2:]), dtype=jnp.float32)
            for k, v in posterior.items()
        }
    core = _predictive_core(model, _obs_key(obs), len(keep) * n_chains)
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
    coords = {"surface": list(obs.surfaces), "window": np.arange(used), "draw": keep}
    # The thinned groups have their own draw coordinate, so they are built apart and attached.
    extra = azb.from_dict(
        {"log_likelihood": loglik, "posterior_predictive": ppc}, dims=_DIMS, coords=coords
    )
    for name in ("log_likelihood", "posterior_predictive"):
        idata[name] = extra[name]


def observations_from_fit(fit: Fit) -> TyreObservations:
    """The (weighted) observations a saved tyre fit was made from, padded as :func:`stack_drives`.

    Raises
    ------
    BadInputError
        The fit is not a tyre fit, or its file does not hold every window's likelihood inputs
        (:data:`WINDOW_FIELDS`; files written before they were kept).
    """
    if fit.kind != "tyre":
        raise BadInputError(f"fit: expected a tyre fit, got a {fit.kind} fit")
    const = fit.data["constant_data"]
    # A fit without the load sensitivity never read the load change (files written before the
    # windows carried it): 0, the static load, is what its likelihood saw.
    optional = set() if "load_sensitivity" in fit.data["posterior"] else {"load_change"}
    missing = [n for n in WINDOW_FIELDS if n not in const.data_vars and n not in optional]
    if missing:
        raise BadInputError(
            f"tyre fit: expected its windows' likelihood inputs in constant_data to recompute "
            f"the per-window draws, missing {missing[0]!r} (refit to get them)"
        )
    observed = fit.data["observed_data"]
    n = int(observed["slip_obs"].shape[0])
    size = bucket_size(n)
    fills = {"slip_sd": 1.0, "rho_sd": 1.0, "temperature_c": 20.0, "slip_weight": 1.0}

    def padded(values, fill=0):
        values = np.asarray(values)
        return jnp.asarray(np.concatenate([values, np.full(size - n, fill, dtype=values.dtype)]))

    fields = {
        name: padded(const[name] if name in const.data_vars else np.zeros(n), fills.get(name, 0))
        for name in WINDOW_FIELDS
    }
    return TyreObservations(
        slip=padded(observed["slip_obs"]),
        rho=padded(observed["rho_obs"]),
        mask=jnp.asarray(np.arange(size) < n),
        # The posterior's per-drive sites set the drive count (a drive may have no window).
        n_drives=int(fit.data["posterior"]["slip_offset"].shape[-1]),
        surfaces=tuple(fit.attr("surfaces")),
        **fields,
    )


def with_pointwise(fit: Fit) -> Fit:
    """``fit`` with its per-window log-likelihood and posterior predictive groups.

    A fit that has them is returned as it is; one made with ``pointwise=False`` gets them
    recomputed from its posterior, its windows (:func:`observations_from_fit`) and its stored
    predictive key: the same draws its fit would have stored.

    Examples
    --------
    >>> fit = with_pointwise(load_fit("set.fit.nc"))  # doctest: +SKIP
    >>> fit.data["posterior_predictive"]["slip_obs"].shape  # doctest: +SKIP
    (1, 200, 15395)
    """
    if "posterior_predictive" in fit.data.children and "log_likelihood" in fit.data.children:
        return fit
    obs = observations_from_fit(fit)
    if _KEY_ATTR not in fit.data.attrs:
        raise BadInputError("tyre fit: expected its predictive key in attrs, found none")
    key = jnp.asarray(fit.attr(_KEY_ATTR), dtype=jnp.uint32)
    posterior = {
        name: np.asarray(fit.data["posterior"][name]) for name in fit.data["posterior"].data_vars
    }
    data = fit.data.copy()
    _attach_pointwise(data, posterior, obs, str(fit.data.attrs["tyre_model"]), key)
    return Fit(data=data, diagnostics=fit.diagnostics, kind=fit.kind, provenance=fit.provenance)


def _scalar_diagnostics(
    idata: xr.DataTree,
    method: str = "nuts",
    *,
    optimiser_result: str = "n/a",
    problems: tuple[str, ...] = (),
) -> Diagnostics:
    """:func:`~tyrebayes.inference.result.diagnose` over every parameter but C_x.

    C_x is C_xr times a function of the temperature sensitivity: a deterministic function of
    checked parameters. ``optimiser_result`` and ``problems`` are the MAP + Laplace path's own
    verdict (passed on to ``diagnose``).
    """
    names = [v for v in idata["posterior"].data_vars if v not in ("c_x",)]
    return diagnose(
        idata, method=method, var_names=names, optimiser_result=optimiser_result, problems=problems
    )


def _single_precision(obs: TyreObservations) -> TyreObservations:
    """``obs`` with its floating-point fields in float32 (see :func:`_whitened_model`)."""
    return jax.tree.map(
        lambda x: x.astype(jnp.float32) if jnp.issubdtype(x.dtype, jnp.floating) else x, obs
    )
