"""The stored part of a per-tyre fit: per-window log-likelihood, posterior predictive, the data."""

from __future__ import annotations

import functools

import arviz_base as azb
import jax
import jax.numpy as jnp
import numpy as np
import numpyro.distributions as dist
import xarray as xr

from ...internal.stored_program import stored_program
from ..result import Diagnostics, diagnose
from .data import TyreObservations
from .model import (
    TyrePriors,
    window_likelihood,
)

# Posterior predictive draws kept (memory: draws × windows per observed site).
MAX_PREDICTIVE_DRAWS = 200


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

    # Kept on disk once traced (a new process reads it instead of tracing the model again).
    return stored_program(core, ("tyre-predictive-core", kind, obs_key, n_draws))


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
    # Per-window conditions, so that criticism can scan a saved fit's residuals against them.
    window_data = {
        "at_limit": at_limit,
        "temperature_c": np.asarray(obs.temperature_c, dtype=float)[mask],
        "drive_index": np.asarray(obs.drive_index)[mask],
        "block_index": np.asarray(obs.block_index)[mask],
        "surface_index": np.asarray(obs.surface_index)[mask],
    }
    constant = azb.from_dict(
        {"constant_data": window_data},
        dims={name: ["window"] for name in window_data},
        coords=coords,
    )
    for name in ("log_likelihood", "posterior_predictive"):
        idata[name] = extra[name]
    idata["constant_data"] = constant["constant_data"]
    return idata


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
