"""The per-tyre NumPyro model: joint posterior of C_x, C_xr, μ_max and the nuisances.

Measurement model for window i of drive d on surface s (all quantities normalised, [-]):

    ρ_true,i  ~ p_d                                        (population of forces in the drive)
    ρ_obs,i   = g_d ρ_true,i + ε_ρ,    ε_ρ ~ Normal(0, λ_ρ sρ_i)
    σ_obs,i   = f⁻¹(ρ_true,i; C_x(T_i), μ_s) + s0_d + b_k + ε_σ,   ε_σ ~ Normal(0, λ_σ sσ_i)
    b_k       ~ Normal(0, τ)                               (one offset per 5 s block k)
    C_x,i     = C_xr exp(−κ (T_i − 20 °C)) exp(q ΔF_z,i/F_z)   (temperature; load, opt-in)

with f⁻¹ the inverse of the tyre curve in adhesion: by default the Magic Formula (Pacejka 2006,
4.E9–E18; slope C_x at zero, peak μ) with its shape C and curvature E unknown and their prior the
spread of the measured car/SUV tyres of the shipped database (``model="magic"``,
:mod:`.tyre_curve_prior`): normal driving uses a fraction of μ, so C_x is the secant the drive
measures extrapolated through a shape the drive barely sees, and that doubt belongs in its
posterior; also the brush model (thesis ch. 3, eq. 3.3–3.4), a one-exponent family around it
(``"shaped"``) and the linear model. s0_d is the
per-drive slip at zero force (rolling-radius mismatch between the driven and the reference
wheels, plus IMU bias over C_x: in the linear region the two cannot be told apart, so one offset
carries both), g_d the per-drive force gain (axle load share, IMU gain and body pitch are known
to a few percent only: without it the posterior of C_x would be narrower than what ordinary
sensors can tell) and λ_σ, λ_ρ noise scales on the stated sensor noise.

Why slip on force and not force on slip: both are measured with noise (errors in variables). A
regression of force on noisy slip attenuates the slope by var(σ_true)/var(σ_obs) — with wheel-speed
noise of the size of the slip itself that is a 10–30 % underestimate of C_x. The force, from the
IMU, has noise that is small against its range (a few percent of its variance) and independent
of the wheel speeds, so the model regresses the slip on the force and removes the small rest
exactly: given ρ_obs, ρ_true has mean ρ̂ and variance v, and
σ_obs | ρ_obs ~ Normal(f⁻¹(ρ̂) + s0, √(λ_σ²sσ² + f⁻¹′(ρ̂)² v)) (first order in the force noise).

ρ̂ and v come from Tweedie's formula, ρ̂ = (ρ_obs + η² s(ρ_obs))/g and
v = η²(1 + η² s′(ρ_obs))/g² with η = λ_ρ sρ and s the score of the density of the drive's
measured forces (:func:`tyrebayes.inference.tyre.force_density.force_density_score`, a deconvolved
mixture): it holds whatever the distribution of the true forces. A Gaussian population of true
forces (the simpler alternative) shrinks the dense cruising cluster too little and the tail of hard
accelerations too much; the brush curve read that as curvature: C_x +20 % and μ_max at half the
truth on two simulated one-hour drives with the true slips and Gaussian force noise of 0.012,
against C_x +4 % and μ_max −9 % and −15 % with this form. The score has to be smooth as well as
right: a kernel estimate's score is noisy where the forces are dense, an error in ρ̂ that
attenuated the slope again (two one-hour drives, slips from the brush curve at the true forces
plus slip noise, ideal white force noise of twice the default sensors': C_x +5.6 % and +10.3 %,
λ_ρ read as 0.8; with the deconvolved mixture −0.8 % and +1.5 %, λ_ρ 1.0). The marginal of ρ_obs
keeps a Gaussian summary Normal(g m_d, √(g²τ_d² + η²)) per drive: it carries no information on
C_x or μ_max and serves the log-likelihood and the predictive checks.

Slow errors shared by neighbouring windows — a rolling radius drifting with tyre temperature, an
IMU bias that wanders, road grade the features did not remove — are the blocks' offsets b_k,
integrated out in closed form (:func:`block_offsets`): the slope then comes from how slip and
force vary within blocks. On drives from an independent generator (``benchmarks/
external_drives.py``) the IMU-based force erred by 0.011-0.047 of ρ_x per drive, largely
slowly, and read as slip such errors flatten the slip-on-force relation.

Nearby windows' slip errors are correlated (the features' smoothing spills across windows), so
each window's slip log-likelihood counts with the weight ``obs.slip_weight``, its drive's share
of independent information, which the fits estimate from a first fit's residuals
(:mod:`tyrebayes.inference.tyre.window_correlation`). C_x(T) follows the tyre temperature of each
window, which the pipeline estimates from the drive's speed and loads
(:mod:`tyrebayes.streams.tyre_temperature`); so κ is inferred from the drive's warm-up.

C_x(T) = C_xr exp(−κ (T − 20 °C)) compensates the temperature (the reported ``c_x`` is at the
mean tyre temperature and the static load). Real tyres' stiffness per unit load also changes with
load: q = d ln C_x / d(ΔF_z/F_z) is 0 to 0.80 over the shipped car/SUV tyres (PKX2/PKX1 + PKX3,
:mod:`.curve_prior`), and the driven axle's load moves with the force the drive applies (load
transfer m a_x h/L: a front-driven axle unloads as it pushes). With
:meth:`TyrePriors.with_load_sensitivity` each window's C_x follows its axle's load change
ΔF_z,i/F_z,static (``obs.load_change``, from the features' force balance) through q, whose prior
is the measured tyres' spread; by default q is left out (q = 0). Slip windows are traction only,
where the load change follows the force, so q bends the slip-force relation like the curve's
shape and a drive hardly tells them apart: its posterior stays near the prior, whose mean moves
C_x. On simulated drives whose tyres have the database's load dependences it took the C_x bias
from −1.9/−1.2/+0.2 % to −0.5/−0.4/+1.9 % and the pooled 90 % coverage from 0.78 to 0.83 (36
drives); on the independent generator's drives, whose tyres have none, it cost 2 of 16 in 90 %
coverage (``benchmarks/results/tyre_recovery_load_sensitivity.json``,
``external_drives_load_sensitivity.json``).

ABS windows observe the total normalised force ρ_obs = −g_d r μ_s + ε with r the ratio of an ABS
window's mean force to the peak, one parameter shared by all windows: it is a property of the
ABS controller and of the curve's shape after the peak, so it does not average out over windows.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpyro
import numpyro.distributions as dist

from ..._domain import SURFACES
from ...internal.renamed import renamed_keyword
from ...physics.thermal import stiffness_with_sensitivity
from .curves import CURVE_MODELS, DEFAULT_MODEL, check_model, curve_slip
from .data import TyreObservations
from .likelihood import (
    WindowLikelihood,
    WindowQuantities,
    block_offsets,
    likelihood_of_quantities,
    window_likelihood,
    window_quantities,
)
from .priors import MEASURED_LOAD_SENSITIVITY, TyrePriors


@renamed_keyword("kind", "model", what="the tyre-curve model")
def tyre_model(
    obs: TyreObservations,
    priors: TyrePriors | None = None,
    model: str = DEFAULT_MODEL,
    observed: bool = True,
):
    """NumPyro model of one tyre set's windows (see the module docstring).

    Parameters
    ----------
    obs : TyreObservations
        Window-averaged observations (possibly several drives and surfaces).
    priors : TyrePriors, optional
        Prior scales (default :class:`TyrePriors`).
    model : {"shaped", "brush", "linear"}
        Mean model: the brush model identifies μ_max where the data reach the nonlinear region;
        ``"shaped"`` (the default) adds the curve's shape exponent p (``curve_shape``; p = 1 is
        the brush, :func:`~tyrebayes.physics.tyre.shaped_longitudinal_inverse_and_slope`) for
        tyres whose curve bends later than the brush's; the linear model is for drives that never
        leave the linear region.
    observed : bool
        Condition on the measured slip and force (True) or sample them (posterior predictive).
    """
    priors = TyrePriors() if priors is None else priors
    check_model(model)
    params = _tyre_parameters(obs, priors, model)
    params.update(_drive_nuisances(obs, priors))
    weights = obs.mask.astype(obs.temperature_c.dtype)
    mean_temperature = jnp.sum(weights * obs.temperature_c) / jnp.maximum(jnp.sum(weights), 1.0)
    numpyro.deterministic(
        "c_x",
        stiffness_with_sensitivity(params["c_xr"], mean_temperature, params["temp_sensitivity"]),
    )
    params.update(_optional_parameters(priors))
    lik = window_likelihood(params, obs, model)
    _observe(lik, obs, priors, observed)


def _tyre_parameters(obs: TyreObservations, priors: TyrePriors, model: str) -> dict:
    """The tyre's and the noise scales' sample sites: C_xr, κ, μ_max per surface, the curve."""
    c_xr = numpyro.sample("c_xr", dist.LogNormal(jnp.log(priors.c_xr_median), priors.c_xr_log_sd))
    kappa = numpyro.sample(
        "temp_sensitivity", dist.Normal(priors.temp_sensitivity_mean, priors.temp_sensitivity_sd)
    )
    with numpyro.plate("surface", obs.n_surfaces):
        mu = numpyro.sample(
            "mu_max",
            dist.LogNormal(jnp.log(priors.mu_median(obs.surfaces)), priors.mu_log_sd(obs.surfaces)),
        )
    abs_ratio = numpyro.sample(
        "abs_force_ratio",
        # Not truncated at a hard maximum: NUTS mixed badly against the bound (bulk ESS 61 of
        # 600 draws, the rest ≥ 275), and 1.05 is already two sds out.
        dist.Normal(priors.abs_force_ratio, priors.abs_force_ratio_sd),
    )
    curve = _curve_parameters(priors, model)
    rho_noise_scale = numpyro.sample(
        "rho_noise_scale", dist.LogNormal(0.0, priors.force_noise_log_sd)
    )
    # The stated slip noise is a local estimate of coloured noise; its scale is inferred.
    slip_noise_scale = numpyro.sample(
        "slip_noise_scale", dist.LogNormal(0.0, priors.slip_noise_log_sd)
    )
    return dict(
        c_xr=c_xr,
        temp_sensitivity=kappa,
        mu_max=mu,
        abs_force_ratio=abs_ratio,
        **curve,
        rho_noise_scale=rho_noise_scale,
        slip_noise_scale=slip_noise_scale,
    )


def _curve_parameters(priors: TyrePriors, model: str) -> dict:
    """The curve's shape sites: Magic Formula C and E (``"magic"``), p (``"shaped"``), or none."""
    curve = {}
    if model == "magic":
        shape_excess = numpyro.sample(
            "curve_shape_excess",
            dist.LogNormal(priors.curve_shape_excess_log_mean, priors.curve_shape_excess_log_sd),
        )
        curvature_gap = numpyro.sample(
            "curve_curvature_gap",
            dist.LogNormal(priors.curve_curvature_log_mean, priors.curve_curvature_log_sd),
        )
        curve["curve_shape_c"] = numpyro.deterministic("curve_shape_c", 1.0 + shape_excess)
        curve["curve_curvature_e"] = numpyro.deterministic("curve_curvature_e", 1.0 - curvature_gap)
    if model == "shaped":
        bend = numpyro.sample(
            "curve_bend",
            dist.LogNormal(jnp.log(priors.curve_bend_median), priors.curve_bend_log_sd),
        )
        curve["curve_shape"] = numpyro.deterministic("curve_shape", priors.curve_shape_min + bend)
    return curve


def _drive_nuisances(obs: TyreObservations, priors: TyrePriors) -> dict:
    """Each drive's nuisances: slip offset, force gain, and its forces' level and spread."""
    n_drives = obs.n_drives
    # A drive whose forces the stream pipeline divided by an estimated IMU scale factor (a
    # dashcam's) carries that estimate's uncertainty on top of the car's own spread.
    imu_gain_log_sd = jnp.maximum(
        jax.ops.segment_max(
            jnp.where(obs.mask, obs.imu_gain_log_sd, 0.0), obs.drive_index, num_segments=n_drives
        ),
        0.0,
    )
    force_gain_log_sd = jnp.sqrt(priors.force_gain_log_sd**2 + imu_gain_log_sd**2)
    with numpyro.plate("drive", n_drives):
        slip_offset = numpyro.sample("slip_offset", dist.Normal(0.0, priors.slip_offset_sd))
        force_gain = numpyro.sample("force_gain", dist.LogNormal(0.0, force_gain_log_sd))
        force_level = numpyro.sample("force_level", dist.Normal(0.0, 0.3))
        force_spread = numpyro.sample("force_spread", dist.HalfNormal(priors.force_spread_scale))
    return dict(
        slip_offset=slip_offset,
        force_gain=force_gain,
        force_level=force_level,
        force_spread=force_spread,
    )


def _optional_parameters(priors: TyrePriors) -> dict:
    """The opt-in sites: load sensitivity q, and the slip drift's sd between blocks."""
    params = {}
    if priors.load_sensitive:
        params["load_sensitivity"] = numpyro.sample(
            "load_sensitivity",
            dist.Normal(priors.load_sensitivity_mean, priors.load_sensitivity_sd),
        )
    if priors.slip_drift_median > 0:
        params["slip_drift_sd"] = numpyro.sample(
            "slip_drift_sd",
            dist.LogNormal(jnp.log(priors.slip_drift_median), priors.slip_drift_log_sd),
        )
    return params


def _observe(
    lik: WindowLikelihood, obs: TyreObservations, priors: TyrePriors, observed: bool
) -> None:
    """The likelihood terms: the factors, then each window's force and (weighted) slip."""
    numpyro.factor("force_below_peak", jnp.sum(lik.below_peak))
    # The blocks' slip offsets, integrated out (window_likelihood): with them the slope comes
    # from how slip and force vary within blocks, not from slow errors shared by a block.
    if priors.slip_drift_median > 0:
        numpyro.factor("slip_block_offsets", lik.block_log_correction)
    with numpyro.plate("window", obs.slip.shape[0]):
        with numpyro.handlers.mask(mask=obs.mask):
            numpyro.sample(
                "rho_obs",
                dist.Normal(lik.rho_loc, lik.rho_scale),
                obs=obs.rho if observed else None,
            )
        # Each window's slip counts with the weight of its share of independent information
        # (obs.slip_weight, window_correlation.py): nearby windows' errors are correlated.
        with (
            numpyro.handlers.mask(mask=obs.mask & ~obs.at_limit),
            numpyro.handlers.scale(scale=obs.slip_weight),
        ):
            numpyro.sample(
                "slip_obs",
                dist.Normal(lik.slip_loc, lik.slip_scale),
                obs=obs.slip if observed else None,
            )


__all__ = [
    "DEFAULT_MODEL",
    "MEASURED_LOAD_SENSITIVITY",
    "CURVE_MODELS",
    "check_model",
    "curve_slip",
    "SURFACES",
    "TyrePriors",
    "WindowLikelihood",
    "WindowQuantities",
    "block_offsets",
    "likelihood_of_quantities",
    "tyre_model",
    "window_likelihood",
    "window_quantities",
]
