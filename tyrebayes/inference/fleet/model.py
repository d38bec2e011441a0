"""NumPyro model of a fleet: friction against inverse stiffness, pooled by tyre type.

Per surface *s* and tyre type *t* an intercept ``a[s,t]`` (mu of a set at the type's reference
stiffness), a slope ``b[s,t]`` against z = 100 / C_xr - 100 / c_xr_ref[t] and a residual scale
``sigma[s,t]``; slopes and log-scales partially pooled over types, the slopes non-centred, the
log-scales around the types' mean (:func:`_residual_scales` says why). The stiffness
C_xr of each set is a latent variable, observed with its standard error and drawn from a per-type
log-normal population.

Sets with a lateral estimate c_y also observe the ratio k = c_y / C_xr of their type: log k of a
set is Normal(k_loc[t], k_scale[t]) and its c_y is measured with a log-normal error of relative
size c_y_sd / c_y, so log c_y ~ Normal(log C_xr + k_loc[t], sqrt(k_scale[t]^2 + (c_y_sd/c_y)^2))
with the set's own k integrated out (it is pinned by one measurement, and the marginal keeps the
sampler off a funnel). The ratio replaces the lane change's fixed type relation C_y = k_type ·
C_xr (:mod:`tyrebayes.inference.vmax`). Without any lateral estimate these sites are absent and
the model is the one above, draw for draw.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import numpyro
import numpyro.distributions as dist
from jaxtyping import Array, Float, Int

from .data import FleetData

#: Scale of the inverse stiffness: z is in units of 100 / C_xr.
X_SCALE: float = 100.0


def fleet_model(
    priors: dict,
    tyre_type: Int[Array, " n_tyres"],
    c_obs: Float[Array, " n_tyres"],
    c_sd: Float[Array, " n_tyres"],
    row_tyre: Int[Array, " n_rows"],
    row_surface: Int[Array, " n_rows"],
    y: Float[Array, " n_rows"] | None = None,
    lateral: tuple | None = None,
):
    """NumPyro model of a fleet (module docstring).

    ``priors`` from :func:`_prior_arrays`, restricted to the surfaces in the data
    (``row_surface`` indexes that restricted list). ``lateral`` is ``(set index, log c_y, its
    log-sd)`` of the sets with a lateral estimate (:func:`lateral_arrays`), or None.
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
    sigma = _residual_scales(p, n_s, n_t)

    if lateral is not None:
        _lateral_ratio(p, tyre_type, log_c, *lateral)

    row_type = tyre_type[row_tyre]
    z = X_SCALE / c_xr[row_tyre] - X_SCALE / p["c_xr_ref"][row_type]
    mean = a[row_surface, row_type] + b[row_surface, row_type] * z
    with numpyro.plate("row", row_tyre.shape[0]):
        numpyro.sample("y", dist.Normal(mean, sigma[row_surface, row_type]), obs=y)


def _residual_scales(p: dict, n_s: int, n_t: int):
    """Residual scale ``sigma[s,t]``: log sigma[s,t] = log sigma0[s] + tau_sigma[s] · N(0,1).

    With log sigma0[s] ~ Normal(log sigma, sigma_log_sd) and tau_sigma[s] ~ HalfNormal. Sampled in
    exactly equivalent coordinates: the types' mean log-scale m[s] (centred: every type's rows
    pin their own scale, so m is what the data measure), the types' deviations tau · (z - mean z)
    with z ~ N(0,1) per type, and log sigma0 drawn from its conditional given m and tau, which the
    likelihood does not see. Non-centred around log sigma0, as before, a few types leave sigma0
    free by about tau / sqrt(types) while the data pin sigma[s,t]: sigma0, tau and every type's
    raw deviation then had to move together along a ridge whose width changes with tau, where
    NUTS diverged (the simulated fleets of ``benchmarks/fleet_lateral_ratio.py``: the divergent
    draws sat far up in sigma0, at large tau).
    """
    log_sig = jnp.log(p["sigma"])
    var0 = p["sigma_log_sd"] ** 2
    tau_s = numpyro.sample("tau_sigma", dist.HalfNormal(p["tau_sigma"]).to_event(1))
    # m = log sigma0 + tau · mean(z): Normal(log sigma, sqrt(var0 + tau^2 / n_t)).
    var_m = var0 + tau_s**2 / n_t
    m = numpyro.sample("log_sigma_mean", dist.Normal(log_sig, jnp.sqrt(var_m)).to_event(1))
    z = numpyro.sample("sigma_raw", dist.Normal(0.0, 1.0).expand([n_s, n_t]).to_event(2))
    # Only the deviations from the types' mean enter; mean(z) keeps its N(0, 1/n_t) prior, which
    # is independent of them, so dropping it here leaves the model unchanged.
    dev = tau_s[:, None] * (z - jnp.mean(z, axis=1, keepdims=True))
    # log sigma0 | m, tau: the Gaussian conditional of the joint (log sigma0, m).
    s0_raw = numpyro.sample("sigma0_raw", dist.Normal(0.0, 1.0).expand([n_s]).to_event(1))
    cond_mean = log_sig + var0 / var_m * (m - log_sig)
    cond_sd = jnp.sqrt(var0 * (tau_s**2 / n_t) / var_m)
    numpyro.deterministic("sigma0", jnp.exp(cond_mean + cond_sd * s0_raw))
    return numpyro.deterministic("sigma", jnp.exp(m[:, None] + dev))


def _lateral_ratio(p: dict, tyre_type, log_c, lat_tyre, log_c_y, log_c_y_sd) -> None:
    """The per-type ratio k = c_y / C_xr and the sets' c_y observations (module docstring)."""
    n_t = p["k_ratio"].shape[0]
    k_raw = numpyro.sample("k_loc_raw", dist.Normal(0.0, 1.0).expand([n_t]).to_event(1))
    k_loc = numpyro.deterministic("k_loc", jnp.log(p["k_ratio"]) + p["k_ratio_log_sd"] * k_raw)
    # Log-normal like the stiffness spread: a few sets of a type must not pull it to zero.
    k_scale = numpyro.sample(
        "k_scale", dist.LogNormal(jnp.log(p["k_spread"]), jnp.full(n_t, 0.5)).to_event(1)
    )
    t = tyre_type[lat_tyre]
    with numpyro.plate("lateral_set", lat_tyre.shape[0]):
        numpyro.sample(
            "c_y_obs",
            dist.Normal(log_c[lat_tyre] + k_loc[t], jnp.sqrt(k_scale[t] ** 2 + log_c_y_sd**2)),
            obs=log_c_y,
        )


def lateral_arrays(data: FleetData) -> tuple | None:
    """``(set index, log c_y, log-sd c_y_sd / c_y)`` of the sets with a lateral estimate, or
    None when the table has none."""
    idx = data.lateral_tyres
    if idx.size == 0:
        return None
    c_y = data.c_y[idx]
    return (jnp.asarray(idx), jnp.asarray(np.log(c_y)), jnp.asarray(data.c_y_sd[idx] / c_y))


def row_mean_sigma(samples: dict, data: FleetData, c_ref: np.ndarray):
    """Per draw and row: predictive mean and scale. Shapes (chain, draw, row)."""
    a, b, sigma = samples["a"], samples["b"], samples["sigma"]
    rt, rs = data.row_type, data.row_surface
    c = samples["c_xr_true"][..., data.row_tyre]
    z = X_SCALE / c - X_SCALE / c_ref[rt]
    return a[..., rs, rt] + b[..., rs, rt] * z, sigma[..., rs, rt]


def normal_logpdf(y, mean, sd):
    return -0.5 * ((y - mean) / sd) ** 2 - np.log(sd) - 0.5 * math.log(2 * math.pi)
