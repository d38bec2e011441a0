"""Fitting the fleet model: NUTS for tens to hundreds of sets, mean-field SVI for thousands.

All four surfaces (snow, ice, wet, dry) are always in the result; a surface without rows keeps its
prior, so predictions there are prior predictions (``data.attrs["fitted_surfaces"]`` says which).
"""

from __future__ import annotations

import json
import math

import arviz_base as azb
import jax
import jax.numpy as jnp
import numpy as np
import numpyro
import pandas as pd
import xarray as xr
from numpyro.infer import SVI, Predictive, Trace_ELBO
from numpyro.infer.autoguide import AutoNormal
from numpyro.infer.initialization import init_to_mean

from ..._domain import SURFACES, TYRE_TYPES
from ..._errors import BadInputError
from ...internal.renamed import renamed_keyword
from ..nuts import run_nuts
from ..result import Fit, diagnose, posterior_predictive_adequacy, provenance
from .data import FleetData, fleet_data_from_table
from .model import X_SCALE, fleet_model, lateral_arrays, normal_logpdf, row_mean_sigma
from .priors import FleetPriors, load_tyre_type_priors, prior_arrays, prior_draws


def _fitted_surfaces(data: FleetData) -> np.ndarray:
    return np.unique(data.row_surface)


def _model_args(data: FleetData, priors: FleetPriors) -> tuple:
    fitted = _fitted_surfaces(data)
    local = np.searchsorted(fitted, data.row_surface)
    return (
        prior_arrays(priors, fitted),
        jnp.asarray(data.tyre_type),
        jnp.asarray(data.c_xr),
        jnp.asarray(data.c_xr_sd),
        jnp.asarray(data.row_tyre),
        jnp.asarray(local),
        jnp.asarray(data.y),
        lateral_arrays(data),
    )


def _expand_surfaces(samples: dict, data: FleetData, priors: FleetPriors, seed: int) -> dict:
    """Put fitted-surface draws into all-surface arrays; unfitted surfaces get prior draws."""
    fitted = _fitted_surfaces(data)
    n_chain, n_draw = samples["a"].shape[:2]
    prior = prior_draws(priors, n_chain * n_draw, seed)
    for name, value in prior.items():
        full = value.reshape((n_chain, n_draw) + value.shape[1:]).copy()
        full[:, :, fitted] = samples[name]
        samples[name] = full
    return samples


# Posterior sites kept in the fit's ArviZ data, with their dims.
_POSTERIOR_DIMS = {
    "a": ["surface", "tyre_type"],
    "b": ["surface", "tyre_type"],
    "sigma": ["surface", "tyre_type"],
    "slope": ["surface"],
    "tau_slope": ["surface"],
    "sigma0": ["surface"],
    "tau_sigma": ["surface"],
    "stiff_loc": ["tyre_type"],
    "stiff_scale": ["tyre_type"],
    "c_xr_true": ["tyre"],
}
_TYPE_LEVEL = ("a", "b", "sigma", "slope", "sigma0", "stiff_loc")
# The lateral ratio's sites, present where some set has a lateral estimate.
_LATERAL_DIMS = {"k_loc": ["tyre_type"], "k_scale": ["tyre_type"]}


def _posterior_dims(data: FleetData) -> dict:
    return {**_POSTERIOR_DIMS, **(_LATERAL_DIMS if data.lateral_tyres.size else {})}


def _run_nuts(data, priors, key, num_warmup, num_samples, num_chains, target_accept):
    draws = run_nuts(
        fleet_model,
        _model_args(data, priors),
        seed=key,
        num_warmup=num_warmup,
        num_samples=num_samples,
        num_chains=num_chains,
        init_strategy=init_to_mean,
        target_accept_prob=target_accept,
    )
    samples = dict(draws.samples)
    samples["c_xr_true"] = np.exp(samples.pop("log_c_xr"))
    return samples, {"diverging": draws.diverging}


def _run_svi(data, priors, key, num_steps, num_draws, learning_rate):
    guide = AutoNormal(fleet_model, init_loc_fn=init_to_mean, init_scale=0.05)
    svi = SVI(fleet_model, guide, numpyro.optim.Adam(learning_rate), Trace_ELBO())
    k_fit, k_draw = jax.random.split(key)
    args = _model_args(data, priors)
    result = svi.run(k_fit, num_steps, *args, progress_bar=False)
    losses = np.asarray(result.losses)
    tail = losses[-max(num_steps // 10, 10) :]
    half = len(tail) // 2
    # Converged when the loss is finite and its last tenth no longer trends down by more than
    # its own noise (relative to the number of rows).
    drift = float(np.mean(tail[:half]) - np.mean(tail[half:]))
    noise = float(np.std(tail)) / math.sqrt(max(half, 1)) + 1e-3 * max(len(data.y), 1)
    pred = Predictive(guide, params=result.params, num_samples=num_draws)
    latent = pred(k_draw, *args)
    det = Predictive(
        fleet_model,
        posterior_samples=latent,
        return_sites=list(_posterior_dims(data)) + ["log_c_xr"],
    )(k_draw, *args)
    samples = {k: np.asarray(v)[None] for k, v in {**latent, **det}.items()}
    samples["c_xr_true"] = np.exp(samples.pop("log_c_xr"))
    finite = bool(np.all(np.isfinite(losses)))
    settled = drift < 3 * noise
    info = {
        "final_loss": float(np.mean(tail)),
        "loss_drift": drift,
        "optimiser_result": (
            "successful"
            if finite and settled
            else ("non-finite ELBO loss" if not finite else "loss still decreasing at the end")
        ),
    }
    return samples, info


@renamed_keyword("key", "seed", what="an int")
def fit_fleet(
    table: pd.DataFrame,
    outcome: str = "mu",
    method: str = "nuts",
    *,
    seed: int = 0,
    num_warmup: int = 1000,
    num_samples: int = 1000,
    num_chains: int = 2,
    target_accept: float = 0.95,
    svi_steps: int = 3000,
    svi_draws: int = 500,
    svi_learning_rate: float = 0.02,
    priors: FleetPriors | None = None,
    source: str = "table in memory",
) -> Fit:
    """Fit the hierarchical fleet model to a fleet table.

    Parameters
    ----------
    table : pandas.DataFrame
        Fleet table (DESIGN.md contract): ``tyre_id``, ``tyre_type``, ``c_xr``, optional
        ``c_xr_sd`` (else the priors' ``default_c_xr_sd``), the outcome column, optional
        ``surface``, optional ``c_y`` and ``c_y_sd`` (a set's lateral estimate, empty where it
        has none: :func:`~tyrebayes.inference.fleet.data.fleet_data_from_table`); a row with
        ``c_y`` and an empty outcome adds a set that cornered but never observed the outcome.
    outcome : str
        Column with the friction potential mu_max (thesis eq. 3.3), dimensionless.
    method : {"nuts", "svi"}
        NUTS (exact, for tens to hundreds of sets) or mean-field SVI (10,000 sets in seconds);
        see :data:`~tyrebayes.inference.diagnostics.FIT_METHODS`.
    seed : int
        Randomness of the sampler (``key=`` before; now a TypeError naming ``seed``).
    num_warmup, num_samples, num_chains, target_accept
        NUTS settings; two chains, as for every fit but the per-tyre one
        (:data:`~tyrebayes.inference.diagnostics.FIT_METHODS` says why). At 500 warm-up steps
        and draws and 0.9 target acceptance, 7 of 16 fits of simulated 120-set fleets missed
        the convergence policy (R-hat, bulk ESS, divergences); at these defaults none
        did (``benchmarks/results/fleet_nuts.json``).
    svi_steps, svi_draws, svi_learning_rate
        SVI settings (Adam steps, posterior draws kept, step size).
    priors : FleetPriors, optional
        Default :func:`load_tyre_type_priors`.

    source : str
        Where the table came from (a path), recorded in the fit's provenance.

    Returns
    -------
    Fit
        ``kind="fleet"``. ``data`` holds ``posterior`` (a, b, sigma per surface and type;
        slope/scale hyper-parameters; stiffness population; ``c_xr_true`` per set; where some
        set has a lateral estimate, ``k_loc`` and ``k_scale`` per type, the log-normal
        population of the ratio c_y / C_xr),
        ``observed_data``, ``log_likelihood`` and ``posterior_predictive`` (variable named after
        ``outcome``, per row), ``constant_data`` and (NUTS) ``sample_stats``; ``data.attrs``
        carries ``c_xr_ref``, ``fitted_surfaces``, ``outcome``, ``x_scale``, the SVI loss and
        ``lateral_sets_per_type`` (JSON). ``diagnostics`` judge the type-level parameters of
        the fitted surfaces (the others are prior draws) and the lateral ratio's, under
        :data:`tyrebayes.inference.result.POLICY`; ``adequate`` reports a posterior predictive
        check of the outcome's mean and sd.

    Examples
    --------
    >>> from tyrebayes.simulate.fleet import simulate_fleet
    >>> table, _ = simulate_fleet(0, 26)
    >>> fit = fit_fleet(table, num_warmup=200, num_samples=200)  # doctest: +SKIP
    >>> fit.converged  # doctest: +SKIP
    True
    """
    if method not in ("nuts", "svi"):
        raise BadInputError(f"method: expected 'nuts' or 'svi', got {method!r}")
    priors = load_tyre_type_priors() if priors is None else priors
    data = fleet_data_from_table(
        table, outcome, default_c_xr_sd=priors.default_c_xr_sd, lateral_only_rows=True
    )
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise TypeError(f"seed: expected an int, got {type(seed).__name__}")
    rng_key = jax.random.key(int(seed))
    if method == "nuts":
        samples, info = _run_nuts(
            data, priors, rng_key, num_warmup, num_samples, num_chains, target_accept
        )
    else:
        samples, info = _run_svi(data, priors, rng_key, svi_steps, svi_draws, svi_learning_rate)
    samples = _expand_surfaces(
        samples, data, priors, seed=int(np.asarray(jax.random.randint(rng_key, (), 0, 2**31 - 1)))
    )
    tree = _to_datatree(samples, data, priors, info, rng_key)
    fitted = sorted({SURFACES[i] for i in data.row_surface}, key=SURFACES.index)
    # Only the fitted surfaces: the others are independent prior draws.
    diagnostics = diagnose(
        tree,
        method=method,
        var_names=_TYPE_LEVEL + (tuple(_LATERAL_DIMS) if data.lateral_tyres.size else ()),
        coords={"surface": fitted},
        optimiser_result=info.get("optimiser_result", "n/a"),
    ).with_adequacy(posterior_predictive_adequacy(tree, outcome))
    settings = (
        {"num_warmup": num_warmup, "num_samples": num_samples, "num_chains": num_chains}
        if method == "nuts"
        else {"svi_steps": svi_steps, "svi_draws": svi_draws}
    )
    return Fit(
        data=tree,
        diagnostics=diagnostics,
        kind="fleet",
        provenance=provenance(
            method, "hierarchical", (source,), outcome=outcome, seed=int(seed), **settings
        ),
    )


def _to_datatree(samples, data, priors, info, rng_key) -> xr.DataTree:
    c_ref = np.asarray(priors.c_xr_ref, float)
    mean, sd = row_mean_sigma(samples, data, c_ref)
    rng = np.random.default_rng(
        np.asarray(jax.random.key_data(jax.random.fold_in(rng_key, 1))).ravel().tolist()
    )
    y_rep = mean + sd * rng.standard_normal(mean.shape)
    name = data.outcome
    coords = {
        "surface": list(SURFACES),
        "tyre_type": list(TYRE_TYPES),
        "tyre": list(data.tyre_ids),
        "row": np.arange(len(data.y)),
    }
    groups = {
        "posterior": {k: samples[k] for k in _posterior_dims(data)},
        "posterior_predictive": {name: y_rep},
        "log_likelihood": {name: normal_logpdf(data.y, mean, sd)},
        "observed_data": {name: data.y},
        "constant_data": {
            "row_tyre": data.row_tyre,
            "row_surface": data.row_surface,
            "row_type": data.row_type,
            "tyre_type_index": data.tyre_type,
            "c_xr_obs": data.c_xr,
            "c_xr_sd": data.c_xr_sd,
            "c_y_obs": data.c_y,
            "c_y_sd": data.c_y_sd,
        },
    }
    if "diverging" in info:
        groups["sample_stats"] = {"diverging": info["diverging"]}
    fitted = sorted({SURFACES[i] for i in data.row_surface}, key=SURFACES.index)
    svi = {k: v for k, v in info.items() if k in ("final_loss", "loss_drift")}
    tree = azb.from_dict(
        groups,
        coords=coords,
        dims={
            **_posterior_dims(data),
            name: ["row"],
            "row_tyre": ["row"],
            "row_surface": ["row"],
            "row_type": ["row"],
            "tyre_type_index": ["tyre"],
            "c_xr_obs": ["tyre"],
            "c_xr_sd": ["tyre"],
            "c_y_obs": ["tyre"],
            "c_y_sd": ["tyre"],
        },
    )
    # Kind-specific facts a prediction from a loaded fit needs (netCDF attributes: strings).
    tree.attrs.update(
        {
            "c_xr_ref": json.dumps(c_ref.tolist()),
            "tyre_types": json.dumps(list(TYRE_TYPES)),
            "surfaces": json.dumps(list(SURFACES)),
            "fitted_surfaces": json.dumps(fitted),
            "outcome": name,
            "x_scale": X_SCALE,
            "svi": json.dumps(svi),
            # Sets with a lateral estimate per type: a type without any keeps its prior ratio.
            "lateral_sets_per_type": json.dumps(
                {
                    t: int(np.sum(data.tyre_type[data.lateral_tyres] == i))
                    for i, t in enumerate(TYRE_TYPES)
                }
            ),
        }
    )
    return tree
