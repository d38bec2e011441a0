"""The per-tyre NumPyro model: joint posterior of C_x, C_xr, μ_max and the nuisances.

Measurement model for window i of drive d on surface s (all quantities normalised, [-]):

    σ_true,i  ~ Normal(m_i, τ_i),  m_i = a_d + β_d ν_i  (structural errors in variables)
    σ_obs,i   = σ_true,i + ε_σ,   ε_σ ~ Normal(0, sσ_i)  (sσ known from the sensor noise)
    ρ_obs,i   = f(σ_true,i − s0_d; C_x(T_i), μ_s) + b_d + ε_ρ,  ε_ρ ~ Normal(0, λ sρ_i)
    C_x(T)    = C_xr exp(−κ (T − 20 °C))               (stiffness temperature compensation)

with ν_i the measured slip of the neighbouring windows (an instrument: its noise is independent
of window i's, the true slip changes slowly), τ_i² = τ0_d² + (τ1_d ν_i)², f the brush model
(thesis ch. 3; slope C_x, peak μ, eq. 3.3–3.4) or the linear model, s0_d the
per-drive slip offset (rolling-radius mismatch), b_d the per-drive force offset (IMU bias /
mounting pitch) and λ a force-noise scale.

The latent true slip is integrated out: σ_obs ~ Normal(m_i, √(τ_i² + sσ²)) and, given σ_obs, the
true slip is Normal(σ̂, v) with σ̂ = m + w(σ_obs − m), w = τ²/(τ² + sσ²), v = w sσ². Linearising f
around σ̂ gives ρ_obs | σ_obs ~ Normal(f(σ̂) + b, √(λ² sρ² + f′(σ̂)² v)). For the linear model this
factorisation of the bivariate normal is exact, which is why the slope is not attenuated: the
naive regression of ρ on σ_obs estimates w·C_x instead of C_x. In the nonlinear region the
windows' slip noise is small (v ≪ peak slip²) and the linearisation error is negligible.

Geometry: in the linear region only the intercept a = b − C_x s0 is identified, so the model
samples that intercept and puts the stated prior on b = a + C_x s0 as a factor (a shift, unit
Jacobian): the same posterior without the b–s0 ridge that slows NUTS.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpyro
import numpyro.distributions as dist

from ..physics.tyre import brush_longitudinal
from .tyre_data import SURFACES, TyreObservations

REFERENCE_TEMPERATURE_C = 20.0

# Prior medians of μ_max per surface: dry asphalt ~1.0, wet ~0.75, packed snow ~0.35, ice ~0.12
# (ranges of the measured braking data in tyrebayes/data/braking_by_tyre_type.csv, which give
# lower bounds 0.8-1.1 dry, 0.6-0.8 wet, 0.3-0.45 snow, 0.1-0.15 ice from mean deceleration).
_MU_MEDIAN = {"dry": 1.0, "wet": 0.75, "snow": 0.35, "ice": 0.12}


class TyrePriors(eqx.Module):
    """Prior scales of the per-tyre model (reviewed numbers; each says where it comes from).

    Fields
    ------
    c_xr_median : float
        Median of C_xr [-]; 35 is mid-range of the thesis' Table 6.2 (29–60).
    c_xr_log_sd : float
        Log-scale sd of C_xr; 0.45 puts 90 % between 17 and 73.
    temp_sensitivity_mean, temp_sensitivity_sd : float
        κ in C_x(T) = C_xr exp(−κ(T − 20)) [1/K]; rubber stiffness falls ~0.5–1 %/K around
        room temperature, so 0.008 ± 0.006.
    mu_log_sd : float
        Log-scale sd of μ_max around the surface medians (0.35: a factor 1.4 either way).
    slip_offset_sd : float
        Per-drive slip offset sd [-]: rolling radii differ by fractions of a percent (0.01).
    rho_offset_sd : float
        Per-drive force offset sd [-]: IMU bias ~0.1–0.3 m/s² over g·(axle load share) → 0.03.
    true_slip_scale : float
        Half-normal scale of the spread τ_d of true slip within a drive [-].
    abs_force_ratio, abs_force_ratio_sd : float
        Window-mean |ρ_x| of an ABS window as a fraction of μ_max, and its spread: ABS cycles
        the slip around the peak (about 0.5–1.5 peak slip), where the brush curve delivers
        0.9–1.0 μ and measured Magic Formula curves 0.9–1.0 μ (they fall slowly after the peak).
    """

    c_xr_median: float = 35.0
    c_xr_log_sd: float = 0.45
    temp_sensitivity_mean: float = 0.008
    temp_sensitivity_sd: float = 0.006
    mu_log_sd: float = 0.35
    slip_offset_sd: float = 0.01
    rho_offset_sd: float = 0.03
    true_slip_scale: float = 0.05
    abs_force_ratio: float = 0.96
    abs_force_ratio_sd: float = 0.04

    def mu_median(self, surfaces: tuple[str, ...]) -> jax.Array:
        return jnp.array([_MU_MEDIAN[s] for s in surfaces])


def stiffness_at_temperature(c_xr, temp_sensitivity, temperature_c):
    """C_x(T) = C_xr exp(−κ (T − 20 °C)): the compensation model of thesis ch. 3.3.1, inferable."""
    return c_xr * jnp.exp(-temp_sensitivity * (temperature_c - REFERENCE_TEMPERATURE_C))


def _force_and_slope(kind: str, slip, c_x, mu, slide_ratio):
    """Model force f(σ) and its slope f′(σ), elementwise."""
    if kind == "linear":
        return c_x * slip, c_x
    return jax.jvp(
        lambda s: brush_longitudinal(s, c_x, mu, slide_ratio), (slip,), (jnp.ones_like(slip),)
    )


def tyre_model(
    obs: TyreObservations,
    priors: TyrePriors | None = None,
    kind: str = "brush",
    observed: bool = True,
):
    """NumPyro model of one tyre set's windows (see the module docstring).

    Parameters
    ----------
    obs : TyreObservations
        Window-averaged observations (possibly several drives and surfaces).
    priors : TyrePriors, optional
        Prior scales (default :class:`TyrePriors`).
    kind : {"brush", "linear"}
        Mean model: the brush model identifies μ_max where the data reach the nonlinear region;
        the linear model is for drives that never leave the linear region.
    observed : bool
        Condition on the measured slip and force (True) or sample them (posterior predictive).
    """
    priors = TyrePriors() if priors is None else priors
    if kind not in ("brush", "linear"):
        raise ValueError(f"tyre model kind: expected 'brush' or 'linear', got {kind!r}")
    n_drives, n_surfaces = obs.n_drives, obs.n_surfaces

    c_xr = numpyro.sample("c_xr", dist.LogNormal(jnp.log(priors.c_xr_median), priors.c_xr_log_sd))
    kappa = numpyro.sample(
        "temp_sensitivity", dist.Normal(priors.temp_sensitivity_mean, priors.temp_sensitivity_sd)
    )
    with numpyro.plate("surface", n_surfaces):
        mu = numpyro.sample(
            "mu_max", dist.LogNormal(jnp.log(priors.mu_median(obs.surfaces)), priors.mu_log_sd)
        )
    slide_ratio = numpyro.sample("mu_slide_ratio", dist.Uniform(0.5, 1.0))
    rho_noise_scale = numpyro.sample("rho_noise_scale", dist.LogNormal(0.0, 0.5))
    # The stated slip noise is a local estimate of coloured noise; its scale is inferred.
    slip_noise_scale = numpyro.sample("slip_noise_scale", dist.LogNormal(0.0, 0.3))
    with numpyro.plate("drive", n_drives):
        slip_offset = numpyro.sample("slip_offset", dist.Normal(0.0, priors.slip_offset_sd))
        intercept = numpyro.sample("rho_intercept", dist.Normal(0.0, 0.3))
        slip_level = numpyro.sample("true_slip_level", dist.Normal(0.0, 0.02))
        slip_gain = numpyro.sample("true_slip_gain", dist.Normal(1.0, 0.5))
        spread_base = numpyro.sample("true_slip_spread", dist.HalfNormal(priors.true_slip_scale))
        spread_gain = numpyro.sample("true_slip_spread_gain", dist.HalfNormal(1.0))

    weights = obs.mask.astype(obs.temperature_c.dtype)
    d = obs.drive_index
    drive_temperature = jax.ops.segment_sum(
        weights * obs.temperature_c, d, num_segments=n_drives
    ) / jnp.maximum(jax.ops.segment_sum(weights, d, num_segments=n_drives), 1.0)
    c_x_drive = stiffness_at_temperature(c_xr, kappa, drive_temperature)
    # The stated prior on the force offset b = a + C_x s0 (IMU bias), entered as a factor.
    rho_offset = numpyro.deterministic("rho_offset", intercept + c_x_drive * slip_offset)
    numpyro.factor(
        "rho_offset_prior", dist.Normal(0.0, priors.rho_offset_sd).log_prob(rho_offset).sum()
    )
    mean_temperature = jnp.sum(weights * obs.temperature_c) / jnp.maximum(jnp.sum(weights), 1.0)
    numpyro.deterministic("c_x", stiffness_at_temperature(c_xr, kappa, mean_temperature))

    m = slip_level[d] + slip_gain[d] * obs.neighbour_slip
    tau2 = spread_base[d] ** 2 + (spread_gain[d] * obs.neighbour_slip) ** 2
    noise2 = (slip_noise_scale * obs.slip_sd) ** 2
    shrink = tau2 / (tau2 + noise2)
    slip_hat = m + shrink * (obs.slip - m)
    slip_var = shrink * noise2
    c_x = stiffness_at_temperature(c_xr, kappa, obs.temperature_c)
    force, slope = _force_and_slope(
        kind, slip_hat - slip_offset[d], c_x, mu[obs.surface_index], slide_ratio
    )
    rho_scale = jnp.sqrt((rho_noise_scale * obs.rho_sd) ** 2 + slope**2 * slip_var)

    # ABS windows: the total force sits near the peak, the slip is not measurable.
    mu_window = mu[obs.surface_index]
    limit_scale = jnp.sqrt(
        (rho_noise_scale * obs.rho_sd) ** 2 + (priors.abs_force_ratio_sd * mu_window) ** 2
    )
    rho_mean = jnp.where(obs.at_limit, -priors.abs_force_ratio * mu_window, force + rho_offset[d])
    rho_scale = jnp.where(obs.at_limit, limit_scale, rho_scale)

    with numpyro.plate("window", obs.slip.shape[0]):
        with numpyro.handlers.mask(mask=obs.mask & ~obs.at_limit):
            numpyro.sample(
                "slip_obs",
                dist.Normal(m, jnp.sqrt(tau2 + noise2)),
                obs=obs.slip if observed else None,
            )
        with numpyro.handlers.mask(mask=obs.mask):
            numpyro.sample(
                "rho_obs", dist.Normal(rho_mean, rho_scale), obs=obs.rho if observed else None
            )


__all__ = ["SURFACES", "TyrePriors", "stiffness_at_temperature", "tyre_model"]
