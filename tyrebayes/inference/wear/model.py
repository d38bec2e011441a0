"""NumPyro model of tread wear (package docstring), and its starting point."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import numpyro
import numpyro.distributions as dist

from ...physics.thermal import StiffnessTemperature, stiffness_at_temperature
from .data import WearData, WearPriors


def wear_factor(grid_c, c_xr, kappa, comp: StiffnessTemperature):
    """exp(kappa (T_b - 20)) / C_x(C_xr, T_b): volume per unit gamma_ref and unit kernel."""
    grid = jnp.asarray(grid_c)[None, :]
    c_x = stiffness_at_temperature(jnp.asarray(c_xr)[:, None], grid, comp)
    return jnp.exp(jnp.asarray(kappa)[:, None] * (grid - 20.0)) / c_x


def wear_model(
    data: WearData,
    extended: bool = False,
    priors: WearPriors | None = None,
    comp: StiffnessTemperature | None = None,
):
    """NumPyro model of the module docstring (``extended`` adds kappa per tyre type)."""
    priors = WearPriors() if priors is None else priors
    comp = StiffnessTemperature() if comp is None else comp
    n_sets, n_types = data.n_sets, data.n_types
    with numpyro.plate("types", n_types):
        mu = numpyro.sample(
            "mu_log_gamma",
            dist.Normal(np.log(priors.gamma_median_mm3_per_j), priors.gamma_log_sd),
        )
        if extended:
            kappa_t = numpyro.sample("kappa", dist.Normal(0.0, priors.kappa_sd_per_k))
        else:
            kappa_t = jnp.zeros(n_types)
    set_type = jnp.asarray(data.set_type)
    # pooling needs two sets of one type; with one, (mu, log gamma) is a ridge only priors bound
    pooled = np.bincount(data.set_type, minlength=n_types).max() > 1
    if pooled:
        tau = numpyro.sample("tau", dist.HalfNormal(priors.type_spread_log_sd))
    else:
        tau = numpyro.deterministic("tau", jnp.zeros(()))
    with numpyro.plate("sets", n_sets):
        # centred: each set's readings inform its gamma well, where non-centring makes funnels
        log_gamma = (
            numpyro.sample("log_gamma", dist.Normal(mu[set_type], tau)) if pooled else mu[set_type]
        )
        log_c = numpyro.sample(
            "log_c_xr", dist.Normal(jnp.asarray(data.c_xr_log_mean), jnp.asarray(data.c_xr_log_sd))
        )
        # radius quantities are sampled in units of 1e-3 so all parameters are O(1) for NUTS
        offset = numpyro.sample(
            "radius_offset_permille", dist.Normal(0.0, 1e3 * priors.radius_offset_sd)
        )
        with numpyro.plate("axles", 2, dim=-2):
            d0 = numpyro.sample(
                "initial_depth_mm",
                dist.Normal(priors.initial_depth_mm, priors.initial_depth_sd_mm),
            )
    c_xr = numpyro.deterministic("c_xr", jnp.exp(log_c))
    gamma = numpyro.deterministic("gamma", jnp.exp(log_gamma))
    factor = wear_factor(data.grid_c, c_xr, kappa_t[set_type], comp)  # (s, b)
    volume = gamma[:, None, None] * jnp.einsum("sdab,sb->sda", jnp.asarray(data.kernel), factor)
    loss = jnp.cumsum(volume, axis=1) / data.wear_area_mm2
    loss = jnp.concatenate([jnp.zeros((n_sets, 1, 2)), loss], axis=1)  # after 0..D drives
    if data.depth_mm.size:
        sigma_d = numpyro.sample("sigma_depth_mm", dist.HalfNormal(priors.depth_noise_scale_mm))
        mean = (
            d0[data.depth_axle, data.depth_set]
            - loss[data.depth_set, data.depth_drive, data.depth_axle]
        )
        with numpyro.plate("depth_readings", data.depth_mm.size):
            numpyro.sample("depth", dist.Normal(mean, sigma_d), obs=jnp.asarray(data.depth_mm))
    if data.drift_mask.any():
        sigma_r = numpyro.sample(
            "sigma_radius_permille", dist.HalfNormal(1e3 * priors.radius_noise_scale)
        )
        rows, cols = np.nonzero(data.drift_mask)
        rel = loss[rows, cols + 1, 0] - loss[rows, cols + 1, 1]
        mean = offset[rows] - 1e3 * data.radius_per_depth_over_r0 * rel
        with numpyro.plate("drives", rows.size):
            numpyro.sample(
                "drift_permille",
                dist.Normal(mean, sigma_r),
                obs=jnp.asarray(1e3 * data.drift[rows, cols]),
            )


def init_values(data: WearData, extended: bool, priors: WearPriors) -> dict:
    # Start at the prior centre; explicit values avoid init_to_median's batched trial draws
    # (rank promotion is strict in this package's tests).
    values = {
        "mu_log_gamma": jnp.full(data.n_types, np.log(priors.gamma_median_mm3_per_j)),
        "log_c_xr": jnp.asarray(data.c_xr_log_mean),
        "radius_offset_permille": jnp.zeros(data.n_sets),
        "initial_depth_mm": jnp.full((2, data.n_sets), priors.initial_depth_mm),
        "sigma_depth_mm": jnp.asarray(0.5 * priors.depth_noise_scale_mm),
        "sigma_radius_permille": jnp.asarray(500.0 * priors.radius_noise_scale),
        "tau": jnp.asarray(0.5 * priors.type_spread_log_sd),
        "log_gamma": jnp.full(data.n_sets, np.log(priors.gamma_median_mm3_per_j)),
    }
    if extended:
        values["kappa"] = jnp.zeros(data.n_types)
    return values
