"""Hierarchical fleet model: friction potential against inverse stiffness, pooled by tyre type.

The thesis (Sec. 6.1) fitted one least-squares line mu = b0 + b1 / C_xr through 26 winter tests.
This model keeps its physics (softer tyres grip better on snow) but knows what it does not know:

* per surface *s* and tyre type *t* an intercept ``a[s,t]`` (mu of a set at the type's reference
  stiffness), a slope ``b[s,t]`` against z = 100 / C_xr - 100 / c_xr_ref[t] and a residual scale
  ``sigma[s,t]``; slopes and log-scales partially pooled over types, all non-centred;
* the stiffness C_xr of each set is a latent variable, observed with its standard error
  ``c_xr_sd`` (``c_xr ~ Normal(C_xr, c_xr_sd)``) and drawn from a per-type log-normal population;
* priors per type and surface from ``models/priors/tyre_types.toml`` (each number sourced there).

All four surfaces (snow, ice, wet, dry) are always in the model; a surface without rows keeps its
prior, so predictions there are prior predictions (``attrs["fitted_surfaces"]`` says which).

Fit with :func:`fit_fleet` (NUTS for small fleets, SVI for large ones); predict a new set with
:func:`predict_friction`; score held-out rows with :func:`predictive_logpdf`.
"""

from __future__ import annotations

import json
import math
import tomllib
from functools import lru_cache
from pathlib import Path

import arviz as az
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import numpyro
import numpyro.distributions as dist
import pandas as pd
from jaxtyping import Array, Float, Int
from numpyro.infer import MCMC, NUTS, SVI, Predictive, Trace_ELBO
from numpyro.infer.autoguide import AutoNormal
from numpyro.infer.initialization import init_to_mean

from .._errors import BadInputError
from .._resources import models_dir

TYRE_TYPES: tuple[str, ...] = ("winter", "all_season", "summer")
SURFACES: tuple[str, ...] = ("snow", "ice", "wet", "dry")
#: Scale of the inverse stiffness: z is in units of 100 / C_xr.
X_SCALE: float = 100.0
#: R-hat above this (any type-level parameter) marks a NUTS fit as not converged.
RHAT_MAX: float = 1.05
#: Bulk effective sample size below this marks a fit as not converged.
ESS_MIN: float = 100.0
#: Fraction of divergent transitions above this marks a NUTS fit as not converged.
DIVERGENCE_MAX_FRACTION: float = 0.01


# ---------------------------------------------------------------------------------------------
# priors


class FleetPriors(eqx.Module):
    """Prior numbers of the fleet model (see ``models/priors/tyre_types.toml`` for sources).

    Arrays are indexed ``[type]`` (order :data:`TYRE_TYPES`), ``[surface]`` (order
    :data:`SURFACES`) or ``[surface, type]``. Stiffness numbers are dimensionless C_xr; friction
    numbers are dimensionless mu; slopes are mu per unit of z = 100 / C_xr.
    """

    c_xr_ref: np.ndarray
    c_xr_ref_log_sd: np.ndarray
    c_xr_log_sd: np.ndarray
    mu: np.ndarray
    mu_sd: np.ndarray
    slope: np.ndarray
    slope_sd: np.ndarray
    tau_slope: np.ndarray
    sigma: np.ndarray
    sigma_log_sd: np.ndarray
    tau_sigma: np.ndarray
    default_c_xr_sd: float

    def __check_init__(self):
        for name in ("c_xr_ref", "c_xr_ref_log_sd", "c_xr_log_sd", "mu_sd", "slope_sd"):
            value = np.asarray(getattr(self, name))
            if not np.all(value > 0):
                raise ValueError(f"{name}: expected > 0, got {value.tolist()}")
        for name in ("tau_slope", "sigma", "sigma_log_sd", "tau_sigma"):
            value = np.asarray(getattr(self, name))
            if not np.all(value > 0):
                raise ValueError(f"{name}: expected > 0, got {value.tolist()}")
        if not self.default_c_xr_sd > 0:
            raise ValueError(f"default_c_xr_sd: expected > 0, got {self.default_c_xr_sd}")


def load_tyre_type_priors(path: str | Path | None = None) -> FleetPriors:
    """Read the tyre-type priors (default ``models/priors/tyre_types.toml``).

    Examples
    --------
    >>> load_tyre_type_priors().c_xr_ref.tolist()
    [30.0, 40.0, 55.0]
    """
    path = Path(path) if path is not None else models_dir() / "priors" / "tyre_types.toml"
    with open(path, "rb") as fh:
        raw = tomllib.load(fh)
    try:
        types = [raw["types"][t] for t in TYRE_TYPES]
        surfs = [raw["surfaces"][s] for s in SURFACES]
        return FleetPriors(
            c_xr_ref=np.array([t["c_xr_ref"] for t in types], float),
            c_xr_ref_log_sd=np.array([t["c_xr_ref_log_sd"] for t in types], float),
            c_xr_log_sd=np.array([t["c_xr_log_sd"] for t in types], float),
            mu=np.array([[s[t]["mu"] for t in TYRE_TYPES] for s in surfs], float),
            mu_sd=np.array([[s[t]["mu_sd"] for t in TYRE_TYPES] for s in surfs], float),
            slope=np.array([s["slope"] for s in surfs], float),
            slope_sd=np.array([s["slope_sd"] for s in surfs], float),
            tau_slope=np.array([s["tau_slope"] for s in surfs], float),
            sigma=np.array([s["sigma"] for s in surfs], float),
            sigma_log_sd=np.array([s["sigma_log_sd"] for s in surfs], float),
            tau_sigma=np.array([s["tau_sigma"] for s in surfs], float),
            default_c_xr_sd=float(raw["default_c_xr_sd"]),
        )
    except KeyError as err:
        raise BadInputError(f"priors file {path}: expected key {err}, not found") from err


# ---------------------------------------------------------------------------------------------
# data


class FleetData(eqx.Module):
    """A validated fleet table as index arrays (one latent stiffness per tyre set).

    ``tyre_type``, ``c_xr``, ``c_xr_sd`` are per tyre set; ``row_tyre``, ``row_surface``, ``y``
    per row (one row per set and surface).
    """

    tyre_ids: tuple[str, ...]
    tyre_type: np.ndarray
    c_xr: np.ndarray
    c_xr_sd: np.ndarray
    row_tyre: np.ndarray
    row_surface: np.ndarray
    y: np.ndarray
    outcome: str

    @property
    def n_tyres(self) -> int:
        return len(self.tyre_ids)

    @property
    def row_type(self) -> np.ndarray:
        return self.tyre_type[self.row_tyre]


def fleet_data_from_table(
    table: pd.DataFrame,
    outcome: str = "mu",
    *,
    default_c_xr_sd: float | None = None,
    require_outcome: bool = True,
) -> FleetData:
    """Validate a fleet table (DESIGN.md contract) and turn it into :class:`FleetData`.

    Raises :class:`tyrebayes.BadInputError` (one line, expected vs got) for a missing column, an
    unknown tyre type or surface, a non-positive or missing stiffness, a non-finite outcome, a
    tyre set whose rows disagree on its stiffness, or fewer than two rows of a type on a surface.
    Without a ``surface`` column every row is on snow (the thesis' setting).
    """
    if default_c_xr_sd is None:
        default_c_xr_sd = load_tyre_type_priors().default_c_xr_sd
    needed = ["tyre_id", "tyre_type", "c_xr"] + ([outcome] if require_outcome else [])
    missing = [c for c in needed if c not in table.columns]
    if missing:
        raise BadInputError(
            f"fleet table: expected columns {needed}, missing {missing} (got {list(table.columns)})"
        )
    if len(table) == 0:
        raise BadInputError("fleet table: expected at least one row, got none")
    types = table["tyre_type"].astype(str).str.strip()
    unknown = sorted(set(types) - set(TYRE_TYPES))
    if unknown:
        raise BadInputError(f"tyre_type: expected one of {list(TYRE_TYPES)}, got {unknown}")
    if "surface" in table.columns:
        surface = table["surface"].astype(str).str.strip()
        bad = sorted(set(surface) - set(SURFACES))
        if bad:
            raise BadInputError(f"surface: expected one of {list(SURFACES)}, got {bad}")
    else:
        surface = pd.Series("snow", index=table.index)
    c_xr = pd.to_numeric(table["c_xr"], errors="coerce").to_numpy(float)
    if not np.all(np.isfinite(c_xr)):
        raise BadInputError(
            "c_xr: expected a finite stiffness in every row, got "
            f"{int((~np.isfinite(c_xr)).sum())} missing or non-numeric"
        )
    if np.any(c_xr <= 0):
        raise BadInputError(f"c_xr: expected positive stiffness, got minimum {c_xr.min():g}")
    if "c_xr_sd" in table.columns:
        c_sd = pd.to_numeric(table["c_xr_sd"], errors="coerce").to_numpy(float)
        if not np.all(np.isfinite(c_sd) & (c_sd > 0)):
            raise BadInputError("c_xr_sd: expected positive finite values, got missing or <= 0")
    else:
        c_sd = np.full(len(table), float(default_c_xr_sd))
    if require_outcome:
        y = pd.to_numeric(table[outcome], errors="coerce").to_numpy(float)
        if not np.all(np.isfinite(y)):
            raise BadInputError(f"{outcome}: expected finite numbers, got missing or non-numeric")
    else:
        y = np.full(len(table), np.nan)

    ids = table["tyre_id"].astype(str).to_numpy()
    uniq, row_tyre = np.unique(ids, return_inverse=True)
    key = pd.Series(list(zip(ids, surface, strict=True)))
    if key.duplicated().any():
        raise BadInputError(
            f"fleet table: expected one row per tyre_id and surface, got duplicates "
            f"{key[key.duplicated()].iloc[0]}"
        )
    tyre_type = np.zeros(len(uniq), int)
    tyre_c = np.zeros(len(uniq))
    tyre_sd = np.zeros(len(uniq))
    type_idx = types.map({t: i for i, t in enumerate(TYRE_TYPES)}).to_numpy(int)
    for k in range(len(uniq)):
        rows = row_tyre == k
        if len(set(type_idx[rows])) > 1 or np.ptp(c_xr[rows]) > 1e-9:
            raise BadInputError(
                f"tyre_id {uniq[k]}: expected one tyre_type and c_xr for all its rows, got several"
            )
        tyre_type[k], tyre_c[k], tyre_sd[k] = type_idx[rows][0], c_xr[rows][0], c_sd[rows][0]
    row_surface = surface.map({s: i for i, s in enumerate(SURFACES)}).to_numpy(int)
    if require_outcome:
        counts = pd.crosstab(surface.to_numpy(), types.to_numpy())
        thin = [
            (s, t, int(counts.loc[s, t]))
            for s in counts.index
            for t in counts.columns
            if 0 < counts.loc[s, t] < 2
        ]
        if thin:
            s, t, n = thin[0]
            raise BadInputError(
                f"fleet table: expected at least 2 rows per tyre type on a surface to estimate its "
                f"scatter, got {n} for {t} on {s}"
            )
    return FleetData(
        tyre_ids=tuple(uniq.tolist()),
        tyre_type=tyre_type,
        c_xr=tyre_c,
        c_xr_sd=tyre_sd,
        row_tyre=np.asarray(row_tyre, int),
        row_surface=row_surface,
        y=y,
        outcome=outcome,
    )


# ---------------------------------------------------------------------------------------------
# model


def fleet_model(
    priors: dict,
    tyre_type: Int[Array, " n_tyres"],
    c_obs: Float[Array, " n_tyres"],
    c_sd: Float[Array, " n_tyres"],
    row_tyre: Int[Array, " n_rows"],
    row_surface: Int[Array, " n_rows"],
    y: Float[Array, " n_rows"] | None = None,
):
    """NumPyro model of a fleet (module docstring).

    ``priors`` from :func:`_prior_arrays`, restricted to the surfaces in the data
    (``row_surface`` indexes that restricted list).
    """
    p = priors
    n_s, n_t = p["mu"].shape
    # Stiffness population per type. The within-type spread is never near zero (thesis Fig 6.1:
    # winter sets span 25-35), so it gets a log-normal prior; a half-normal would let few sets
    # of a type pull it to 0 and open a funnel with the centred latents below.
    loc_raw = numpyro.sample("stiff_loc_raw", dist.Normal(0.0, 1.0).expand([n_t]).to_event(1))
    stiff_loc = numpyro.deterministic(
        "stiff_loc", jnp.log(p["c_xr_ref"]) + p["c_xr_ref_log_sd"] * loc_raw
    )
    stiff_scale = numpyro.sample(
        "stiff_scale", dist.LogNormal(jnp.log(p["c_xr_log_sd"]), jnp.full(n_t, 0.5)).to_event(1)
    )
    # Centred latents: each set's C_xr is pinned by its own measurement, where centring samples
    # better than non-centring.
    with numpyro.plate("tyre", c_obs.shape[0]):
        log_c = numpyro.sample(
            "log_c_xr", dist.Normal(stiff_loc[tyre_type], stiff_scale[tyre_type])
        )
        c_xr = jnp.exp(log_c)
        numpyro.sample("c_xr_obs", dist.Normal(c_xr, c_sd), obs=c_obs)

    a_raw = numpyro.sample("a_raw", dist.Normal(0.0, 1.0).expand([n_s, n_t]).to_event(2))
    a = numpyro.deterministic("a", p["mu"] + p["mu_sd"] * a_raw)
    slope_raw = numpyro.sample("slope_raw", dist.Normal(0.0, 1.0).expand([n_s]).to_event(1))
    slope = numpyro.deterministic("slope", p["slope"] + p["slope_sd"] * slope_raw)
    tau_b = numpyro.sample("tau_slope", dist.HalfNormal(p["tau_slope"]).to_event(1))
    b_raw = numpyro.sample("b_raw", dist.Normal(0.0, 1.0).expand([n_s, n_t]).to_event(2))
    b = numpyro.deterministic("b", slope[:, None] + tau_b[:, None] * b_raw)
    s0_raw = numpyro.sample("sigma0_raw", dist.Normal(0.0, 1.0).expand([n_s]).to_event(1))
    log_s0 = jnp.log(p["sigma"]) + p["sigma_log_sd"] * s0_raw
    numpyro.deterministic("sigma0", jnp.exp(log_s0))
    tau_s = numpyro.sample("tau_sigma", dist.HalfNormal(p["tau_sigma"]).to_event(1))
    s_raw = numpyro.sample("sigma_raw", dist.Normal(0.0, 1.0).expand([n_s, n_t]).to_event(2))
    sigma = numpyro.deterministic("sigma", jnp.exp(log_s0[:, None] + tau_s[:, None] * s_raw))

    row_type = tyre_type[row_tyre]
    z = X_SCALE / c_xr[row_tyre] - X_SCALE / p["c_xr_ref"][row_type]
    mean = a[row_surface, row_type] + b[row_surface, row_type] * z
    with numpyro.plate("row", row_tyre.shape[0]):
        numpyro.sample("y", dist.Normal(mean, sigma[row_surface, row_type]), obs=y)


def prior_draws(priors: FleetPriors, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Draws of the surface-level parameters from their priors, all four surfaces.

    Used for the surfaces a fleet table has no rows on. Shapes ``(n, 4, 3)`` for a, b, sigma and
    ``(n, 4)`` for slope, tau_slope, sigma0, tau_sigma.
    """
    rng = np.random.default_rng(seed)
    n_s, n_t = priors.mu.shape
    a = priors.mu + priors.mu_sd * rng.standard_normal((n, n_s, n_t))
    slope = priors.slope + priors.slope_sd * rng.standard_normal((n, n_s))
    tau_b = np.abs(priors.tau_slope * rng.standard_normal((n, n_s)))
    b = slope[..., None] + tau_b[..., None] * rng.standard_normal((n, n_s, n_t))
    log_s0 = np.log(priors.sigma) + priors.sigma_log_sd * rng.standard_normal((n, n_s))
    tau_s = np.abs(priors.tau_sigma * rng.standard_normal((n, n_s)))
    sigma = np.exp(log_s0[..., None] + tau_s[..., None] * rng.standard_normal((n, n_s, n_t)))
    return {
        "a": a,
        "b": b,
        "sigma": sigma,
        "slope": slope,
        "tau_slope": tau_b,
        "sigma0": np.exp(log_s0),
        "tau_sigma": tau_s,
    }


def _prior_arrays(priors: FleetPriors, surfaces: np.ndarray) -> dict:
    per_type = ("c_xr_ref", "c_xr_ref_log_sd", "c_xr_log_sd")
    per_surface = (
        "mu",
        "mu_sd",
        "slope",
        "slope_sd",
        "tau_slope",
        "sigma",
        "sigma_log_sd",
        "tau_sigma",
    )
    out = {n: jnp.asarray(getattr(priors, n)) for n in per_type}
    out.update({n: jnp.asarray(np.asarray(getattr(priors, n))[surfaces]) for n in per_surface})
    return out


def _fitted_surfaces(data: FleetData) -> np.ndarray:
    return np.unique(data.row_surface)


def _model_args(data: FleetData, priors: FleetPriors) -> tuple:
    fitted = _fitted_surfaces(data)
    local = np.searchsorted(fitted, data.row_surface)
    return (
        _prior_arrays(priors, fitted),
        jnp.asarray(data.tyre_type),
        jnp.asarray(data.c_xr),
        jnp.asarray(data.c_xr_sd),
        jnp.asarray(data.row_tyre),
        jnp.asarray(local),
        jnp.asarray(data.y),
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


# Posterior sites kept in the InferenceData, with their dims.
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


@lru_cache(maxsize=8)
def _cached_mcmc(shape, num_warmup, num_samples, num_chains, chain_method, accept):
    # One MCMC object per data shape: jit_model_args=True reuses the compiled sampler for new
    # data of the same shape (a refit costs no compilation).
    del shape
    kernel = NUTS(fleet_model, target_accept_prob=accept, init_strategy=init_to_mean)
    return MCMC(
        kernel,
        num_warmup=num_warmup,
        num_samples=num_samples,
        num_chains=num_chains,
        chain_method=chain_method,
        progress_bar=False,
        jit_model_args=True,
    )


def _run_nuts(data, priors, key, num_warmup, num_samples, num_chains, target_accept):
    n_s = len(_fitted_surfaces(data))
    chain_method = "parallel" if jax.local_device_count() >= num_chains else "sequential"
    mcmc = _cached_mcmc(
        (data.n_tyres, len(data.y), n_s),
        num_warmup,
        num_samples,
        num_chains,
        chain_method,
        target_accept,
    )
    mcmc.run(key, *_model_args(data, priors))
    samples = mcmc.get_samples(group_by_chain=True)
    extra = mcmc.get_extra_fields(group_by_chain=True)
    divergences = int(np.asarray(extra["diverging"]).sum())
    samples = {k: np.asarray(v) for k, v in samples.items()}
    samples["c_xr_true"] = np.exp(samples.pop("log_c_xr"))
    return samples, {"divergences": divergences}


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
        fleet_model, posterior_samples=latent, return_sites=list(_POSTERIOR_DIMS) + ["log_c_xr"]
    )(k_draw, *args)
    samples = {k: np.asarray(v)[None] for k, v in {**latent, **det}.items()}
    samples["c_xr_true"] = np.exp(samples.pop("log_c_xr"))
    info = {
        "final_loss": float(np.mean(tail)),
        "loss_drift": drift,
        "loss_finite": bool(np.all(np.isfinite(losses))),
        "svi_converged": bool(np.all(np.isfinite(losses)) and drift < 3 * noise),
    }
    return samples, info


def _row_mean_sigma(samples: dict, data: FleetData, c_ref: np.ndarray):
    """Per draw and row: predictive mean and scale. Shapes (chain, draw, row)."""
    a, b, sigma = samples["a"], samples["b"], samples["sigma"]
    rt, rs = data.row_type, data.row_surface
    c = samples["c_xr_true"][..., data.row_tyre]
    z = X_SCALE / c - X_SCALE / c_ref[rt]
    return a[..., rs, rt] + b[..., rs, rt] * z, sigma[..., rs, rt]


def _normal_logpdf(y, mean, sd):
    return -0.5 * ((y - mean) / sd) ** 2 - np.log(sd) - 0.5 * math.log(2 * math.pi)


def _diagnostics(idata, method: str, info: dict, n_draws: int, fitted: list[str]) -> dict:
    # Only fitted surfaces: the others are independent prior draws.
    post = idata.posterior[list(_TYPE_LEVEL)].sel(surface=fitted)
    diag = {"method": method, **info}
    if method == "nuts":
        rhat = az.rhat(post)
        ess = az.ess(post, method="bulk")
        diag["max_rhat"] = float(max(float(rhat[v].max()) for v in rhat.data_vars))
        diag["min_ess_bulk"] = float(min(float(ess[v].min()) for v in ess.data_vars))
        diag["converged"] = bool(
            diag["max_rhat"] <= RHAT_MAX
            and diag["min_ess_bulk"] >= ESS_MIN
            and info["divergences"] <= DIVERGENCE_MAX_FRACTION * n_draws
        )
    else:
        diag["converged"] = bool(info["svi_converged"])
    return diag


def fit_fleet(
    table: pd.DataFrame,
    outcome: str = "mu",
    method: str = "nuts",
    *,
    key: int | Array = 0,
    num_warmup: int = 500,
    num_samples: int = 500,
    num_chains: int = 2,
    target_accept: float = 0.9,
    svi_steps: int = 3000,
    svi_draws: int = 500,
    svi_learning_rate: float = 0.02,
    priors: FleetPriors | None = None,
) -> az.InferenceData:
    """Fit the hierarchical fleet model to a fleet table.

    Parameters
    ----------
    table : pandas.DataFrame
        Fleet table (DESIGN.md contract): ``tyre_id``, ``tyre_type``, ``c_xr``, optional
        ``c_xr_sd`` (else the priors' ``default_c_xr_sd``), the outcome column, optional
        ``surface``.
    outcome : str
        Column with the friction potential mu_max (thesis eq. 3.3), dimensionless.
    method : {"nuts", "svi"}
        NUTS (exact, for tens to hundreds of sets) or mean-field SVI (10,000 sets in seconds).
    key : int or PRNG key
        Randomness of the sampler.
    num_warmup, num_samples, num_chains, target_accept
        NUTS settings.
    svi_steps, svi_draws, svi_learning_rate
        SVI settings (Adam steps, posterior draws kept, step size).
    priors : FleetPriors, optional
        Default :func:`load_tyre_type_priors`.

    Returns
    -------
    arviz.InferenceData
        Groups ``posterior`` (a, b, sigma per surface and type; slope/scale hyper-parameters;
        stiffness population; ``c_xr_true`` per set), ``observed_data`` and ``log_likelihood``
        (variable named after ``outcome``, per row), ``posterior_predictive``, ``constant_data``;
        ``attrs`` carries ``converged`` (0/1), ``diagnostics`` (JSON: R-hat, ESS, divergences or
        SVI loss), ``c_xr_ref``, ``fitted_surfaces``, ``outcome``, ``method``.

    Examples
    --------
    >>> from tyrebayes.simulate.fleet import simulate_fleet
    >>> table, _ = simulate_fleet(0, 26)
    >>> idata = fit_fleet(table, num_warmup=200, num_samples=200)  # doctest: +SKIP
    >>> bool(idata.attrs["converged"])  # doctest: +SKIP
    True
    """
    if method not in ("nuts", "svi"):
        raise BadInputError(f"method: expected 'nuts' or 'svi', got {method!r}")
    priors = load_tyre_type_priors() if priors is None else priors
    data = fleet_data_from_table(table, outcome, default_c_xr_sd=priors.default_c_xr_sd)
    rng_key = jax.random.key(key) if isinstance(key, int) else key
    if method == "nuts":
        samples, info = _run_nuts(
            data, priors, rng_key, num_warmup, num_samples, num_chains, target_accept
        )
    else:
        samples, info = _run_svi(data, priors, rng_key, svi_steps, svi_draws, svi_learning_rate)
    samples = _expand_surfaces(
        samples, data, priors, seed=int(np.asarray(jax.random.randint(rng_key, (), 0, 2**31 - 1)))
    )
    return _to_inference_data(samples, data, priors, method, info, rng_key)


def _to_inference_data(samples, data, priors, method, info, rng_key) -> az.InferenceData:
    c_ref = np.asarray(priors.c_xr_ref, float)
    mean, sd = _row_mean_sigma(samples, data, c_ref)
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
    idata = az.from_dict(
        posterior={k: samples[k] for k in _POSTERIOR_DIMS},
        posterior_predictive={name: y_rep},
        log_likelihood={name: _normal_logpdf(data.y, mean, sd)},
        observed_data={name: data.y},
        constant_data={
            "row_tyre": data.row_tyre,
            "row_surface": data.row_surface,
            "row_type": data.row_type,
            "tyre_type_index": data.tyre_type,
            "c_xr_obs": data.c_xr,
            "c_xr_sd": data.c_xr_sd,
        },
        coords=coords,
        dims={
            **_POSTERIOR_DIMS,
            name: ["row"],
            "row_tyre": ["row"],
            "row_surface": ["row"],
            "row_type": ["row"],
            "tyre_type_index": ["tyre"],
            "c_xr_obs": ["tyre"],
            "c_xr_sd": ["tyre"],
        },
    )
    n_draws = samples["a"].shape[0] * samples["a"].shape[1]
    fitted = sorted({SURFACES[i] for i in data.row_surface}, key=SURFACES.index)
    diag = _diagnostics(idata, method, info, n_draws, fitted)
    idata.attrs.update(
        {
            "converged": int(diag["converged"]),
            "diagnostics": json.dumps(diag),
            "c_xr_ref": json.dumps(c_ref.tolist()),
            "tyre_types": json.dumps(list(TYRE_TYPES)),
            "surfaces": json.dumps(list(SURFACES)),
            "fitted_surfaces": json.dumps(fitted),
            "outcome": name,
            "method": method,
            "x_scale": X_SCALE,
        }
    )
    return idata


def fleet_diagnostics(idata: az.InferenceData) -> dict:
    """The fit's diagnostics (``converged``, R-hat, ESS, divergences or SVI loss) as a dict."""
    return json.loads(idata.attrs["diagnostics"])


# ---------------------------------------------------------------------------------------------
# prediction


def _draws(idata: az.InferenceData, name: str) -> np.ndarray:
    v = idata.posterior[name].values
    return v.reshape((-1,) + v.shape[2:])


def _check_prediction_inputs(idata, c_xr, c_xr_sd, tyre_type, surface):
    if surface not in SURFACES:
        raise BadInputError(f"surface: expected one of {list(SURFACES)}, got {surface!r}")
    if tyre_type is not None and tyre_type not in TYRE_TYPES:
        raise BadInputError(
            f"tyre type: expected one of {list(TYRE_TYPES)} or none, got {tyre_type!r}"
        )
    if not (np.isfinite(c_xr) and c_xr > 0):
        raise BadInputError(f"c_xr: expected a positive stiffness, got {c_xr}")
    if not (np.isfinite(c_xr_sd) and c_xr_sd >= 0):
        raise BadInputError(f"c_xr_sd: expected >= 0, got {c_xr_sd}")
    for name in ("a", "b", "sigma", "stiff_loc", "stiff_scale"):
        if name not in idata.posterior:
            raise BadInputError(f"fleet fit: expected posterior variable {name!r}, not found")


def type_probabilities(idata: az.InferenceData, c_xr: float, c_xr_sd: float) -> np.ndarray:
    """Per posterior draw, P(type | C_xr) with equal prior type shares. Shape (draws, 3).

    A set's measured stiffness is compared with each type's log-normal stiffness population
    (its spread widened by the measurement error). The fleet's own type mix is a sampling
    design, not a population, so it is not used as the prior.
    """
    loc = _draws(idata, "stiff_loc")
    scale = np.sqrt(_draws(idata, "stiff_scale") ** 2 + (c_xr_sd / c_xr) ** 2)
    logp = _normal_logpdf(math.log(c_xr), loc, scale)
    logp -= logp.max(axis=1, keepdims=True)
    w = np.exp(logp)
    return w / w.sum(axis=1, keepdims=True)


def predict_friction(
    fleet_idata: az.InferenceData,
    c_xr: float,
    c_xr_sd: float = 0.0,
    tyre_type: str | None = None,
    surface: str = "snow",
    *,
    seed: int = 0,
) -> np.ndarray:
    """Posterior predictive draws of mu_max for a new tyre set.

    Parameters
    ----------
    fleet_idata : arviz.InferenceData
        A fit from :func:`fit_fleet`.
    c_xr, c_xr_sd : float
        The new set's stiffness posterior, summarised as mean and sd (dimensionless C_xr);
        treated as Normal truncated at 1. ``c_xr_sd = 0`` means an exact value.
    tyre_type : str or None
        ``winter``, ``all_season``, ``summer``; ``None`` mixes over types with
        :func:`type_probabilities`.
    surface : str
        ``snow``, ``ice``, ``wet`` or ``dry``.
    seed : int
        Randomness of the predictive noise.

    Returns
    -------
    numpy.ndarray
        One predictive draw of mu per posterior draw (residual scatter included).

    Examples
    --------
    >>> draws = predict_friction(idata, 30.0, 1.0, "winter")  # doctest: +SKIP
    """
    _check_prediction_inputs(fleet_idata, c_xr, c_xr_sd, tyre_type, surface)
    rng = np.random.default_rng(seed)
    a, b, sigma = (_draws(fleet_idata, n) for n in ("a", "b", "sigma"))
    n = a.shape[0]
    s = SURFACES.index(surface)
    if tyre_type is None:
        w = type_probabilities(fleet_idata, c_xr, c_xr_sd)
        t = (rng.random(n)[:, None] > np.cumsum(w, axis=1)).sum(axis=1)
        t = np.minimum(t, len(TYRE_TYPES) - 1)
    else:
        t = np.full(n, TYRE_TYPES.index(tyre_type))
    c_ref = np.asarray(json.loads(fleet_idata.attrs["c_xr_ref"]))
    c = np.maximum(c_xr + c_xr_sd * rng.standard_normal(n), 1.0)
    idx = np.arange(n)
    z = X_SCALE / c - X_SCALE / c_ref[t]
    mean = a[idx, s, t] + b[idx, s, t] * z
    return mean + sigma[idx, s, t] * rng.standard_normal(n)


def _heldout_mean_sigma(fleet_idata, table, outcome, seed, require_outcome):
    priors = load_tyre_type_priors()
    data = fleet_data_from_table(
        table, outcome, default_c_xr_sd=priors.default_c_xr_sd, require_outcome=require_outcome
    )
    a, b, sigma = (_draws(fleet_idata, n) for n in ("a", "b", "sigma"))
    c_ref = np.asarray(json.loads(fleet_idata.attrs["c_xr_ref"]))
    rng = np.random.default_rng(seed)
    n = a.shape[0]
    c_tyre = np.maximum(
        data.c_xr[None] + data.c_xr_sd[None] * rng.standard_normal((n, data.n_tyres)), 1.0
    )
    rt, rs = data.row_type, data.row_surface
    z = X_SCALE / c_tyre[:, data.row_tyre] - X_SCALE / c_ref[rt]
    return data, a[:, rs, rt] + b[:, rs, rt] * z, sigma[:, rs, rt], rng


def predictive_logpdf(
    fleet_idata: az.InferenceData, table: pd.DataFrame, outcome: str = "mu", *, seed: int = 0
) -> np.ndarray:
    """Log posterior predictive density of each row of a held-out fleet table.

    Each held-out set's stiffness is its measurement (``c_xr`` +- ``c_xr_sd``), as in
    :func:`predict_friction`; its type is the row's ``tyre_type``. Returns one log density per row
    (log of the mean over posterior draws), in the table's row order.
    """
    data, mean, sd, _ = _heldout_mean_sigma(fleet_idata, table, outcome, seed, True)
    lp = _normal_logpdf(data.y[None], mean, sd)
    m = lp.max(axis=0)
    return m + np.log(np.mean(np.exp(lp - m), axis=0))


def predictive_draws(
    fleet_idata: az.InferenceData, table: pd.DataFrame, outcome: str = "mu", *, seed: int = 0
) -> np.ndarray:
    """Posterior predictive draws of the outcome for each row of a (new) fleet table.

    The outcome column may be absent. Returns an array (draws, rows) in the table's row order,
    residual scatter included; stiffness handled as in :func:`predictive_logpdf`.
    """
    _, mean, sd, rng = _heldout_mean_sigma(
        fleet_idata, table, outcome, seed, outcome in table.columns
    )
    return mean + sd * rng.standard_normal(mean.shape)


# ---------------------------------------------------------------------------------------------
# prior predictive check against the measured braking data


#: Average fraction of mu_max an ABS stop realises as mean deceleration (judgement, see TOML).
ABS_EFFICIENCY_RANGE: tuple[float, float] = (0.7, 1.0)


def measured_braking_bounds() -> pd.DataFrame:
    """Mean decelerations v^2 / (2 g d) from the shipped braking data, by type and surface.

    A stop's mean deceleration [g] is a lower bound on mu_max; the summer-on-snow row of What
    Car? gives only "more than twice the winter distance", i.e. an upper bound on its mean
    deceleration (``kind = "upper"``).
    """
    from .._resources import data_dir

    raw = pd.read_csv(data_dir() / "braking_by_tyre_type.csv")
    rows = []
    g = 9.81
    for _, r in raw.iterrows():
        v = float(r["speed_from_kmh"]) / 3.6
        if np.isfinite(r["distance_m"]):
            rows.append(
                (
                    r["source"],
                    r["tyre_type"],
                    r["surface"],
                    v**2 / (2 * g * r["distance_m"]),
                    "lower",
                )
            )
        elif "more than twice" in str(r["note"]):
            winter = raw[
                (raw.source == r.source) & (raw.surface == r.surface) & (raw.tyre_type == "winter")
            ]["distance_m"].iloc[0]
            rows.append(
                (r["source"], r["tyre_type"], r["surface"], v**2 / (2 * g * 2 * winter), "upper")
            )
    return pd.DataFrame(rows, columns=["source", "tyre_type", "surface", "deceleration_g", "kind"])


def prior_predictive_check(
    priors: FleetPriors | None = None, *, n_draws: int = 4000, seed: int = 0
) -> pd.DataFrame:
    """Prior predictive mu of a typical set of each type against the measured braking data.

    For every measured row, draws mu from the prior (type intercept + residual scatter at the
    type's reference stiffness) and compares it with the range of mu_max the measurement allows:
    ``[decel, decel / 0.7]`` for a lower bound (ABS realises 70-100 % of mu_max), ``[0, decel /
    0.7]`` for an upper bound. ``consistent`` is True when the prior's 90 % interval overlaps that
    range and its median lies within ``[0.8 * lo, 1.25 * hi]``.
    """
    priors = load_tyre_type_priors() if priors is None else priors
    rng = np.random.default_rng(seed)
    out = []
    for _, r in measured_braking_bounds().iterrows():
        s, t = SURFACES.index(r.surface), TYRE_TYPES.index(r.tyre_type)
        a = priors.mu[s, t] + priors.mu_sd[s, t] * rng.standard_normal(n_draws)
        sig = priors.sigma[s] * np.exp(priors.sigma_log_sd[s] * rng.standard_normal(n_draws))
        mu = a + sig * rng.standard_normal(n_draws)
        q05, q50, q95 = np.quantile(mu, [0.05, 0.5, 0.95])
        lo = r.deceleration_g / ABS_EFFICIENCY_RANGE[1] if r.kind == "lower" else 0.0
        hi = r.deceleration_g / ABS_EFFICIENCY_RANGE[0]
        consistent = bool(q05 <= hi and q95 >= lo and 0.8 * lo <= q50 <= 1.25 * hi)
        out.append(
            {
                **r.to_dict(),
                "allowed_lo": lo,
                "allowed_hi": hi,
                "prior_q05": q05,
                "prior_median": q50,
                "prior_q95": q95,
                "consistent": consistent,
            }
        )
    return pd.DataFrame(out)
