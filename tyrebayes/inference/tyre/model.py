"""The per-tyre NumPyro model: joint posterior of C_x, C_xr, μ_max and the nuisances.

Measurement model for window i of drive d on surface s (all quantities normalised, [-]):

    ρ_true,i  ~ p_d                                        (population of forces in the drive)
    ρ_obs,i   = g_d ρ_true,i + ε_ρ,    ε_ρ ~ Normal(0, λ_ρ sρ_i)
    σ_obs,i   = f⁻¹(ρ_true,i; C_x(T_i), μ_s) + s0_d + b_k + ε_σ,   ε_σ ~ Normal(0, λ_σ sσ_i)
    b_k       ~ Normal(0, τ)                               (one offset per 5 s block k)
    C_x,i     = C_xr exp(−κ (T_i − 20 °C)) exp(q ΔF_z,i/F_z)   (temperature; load, opt-in)

with f⁻¹ the inverse of the tyre curve in adhesion: by default the Magic Formula (Pacejka 2006,
4.E9–E18; slope C_x at zero, peak μ) with its shape C and curvature E unknown and their prior the
spread of the measured car/SUV tyres of the shipped database (``kind="magic"``,
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

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpyro
import numpyro.distributions as dist

from ..._domain import SURFACES
from ...physics.thermal import stiffness_with_sensitivity
from ...physics.tyre import (
    brush_longitudinal_inverse_and_slope,
    magic_formula_inverse_and_slope,
    shaped_longitudinal_inverse_and_slope,
)
from ..surface_friction import MU_LOG_SD, MU_MEDIAN
from .data import TyreObservations

#: Mean and sd of q = d ln C_x / d(ΔF_z/F_z) over the measured car/SUV tyres, rounded
#: (:func:`~tyrebayes.inference.tyre.curve_prior.curve_shape_prior`; a test holds them to it).
MEASURED_LOAD_SENSITIVITY = (0.263, 0.246)


class TyrePriors(eqx.Module):
    """Prior scales of the per-tyre model (reviewed numbers; each says where it comes from).

    Attributes
    ----------
    c_xr_median : float
        Median of C_xr [-]; 35 is mid-range of the thesis' Table 6.2 (29–60).
    c_xr_log_sd : float
        Log-scale sd of C_xr; 0.45 puts 90 % between 17 and 73.
    temp_sensitivity_mean, temp_sensitivity_sd : float
        κ in C_x(T) = C_xr exp(−κ(T − 20)) [1/K]; rubber stiffness falls ~0.5–1 %/K around
        room temperature, so 0.008 ± 0.006.
    load_sensitivity_mean, load_sensitivity_sd : float
        Normal prior of q in C_x ∝ exp(q ΔF_z/F_z,static) [-]. ``load_sensitivity_sd = 0``, the
        default, leaves q out (one C_x at every load); :meth:`with_load_sensitivity` sets the
        mean and widened sd of PKX2/PKX1 + PKX3 over the 9 distinct car/SUV sets of the shipped
        tyre database (:func:`~tyrebayes.inference.tyre.curve_prior.curve_shape_prior`; 0 to
        0.80 among them, mean 0.263, sd 0.246). Off by default because slip windows are
        traction only, where the load follows the force, so q bends the slip-force relation
        like the curve's shape does and a drive hardly tells them apart: its prior mean then
        moves C_x. On the package's simulator, whose tyres have the database's load
        dependences, it helps; on the independent generator's drives, whose tyres have none, it
        costs (module docstring).
    slip_offset_sd : float
        Per-drive slip at zero force [-]: rolling radii differ by fractions of a percent
        (DESIGN.md physics notes), the driven-minus-reference difference has sd ~0.004.
    force_gain_log_sd : float
        Log-scale sd of the per-drive force gain g_d, the measured over the true ρ_x. The mass
        cancels from F_x/F_z; what does not is where it sits and how the IMU reads a_x: the static
        load share of the driven axle ±2 % (passengers, luggage), the IMU scale factor ±1 %, the
        pitch gradient's over-read of a_x ±0.5 %.
        :class:`~tyrebayes.simulate.vehicle_truth.VehicleSpread` draws cars with these errors;
        their gains have a log-sd of 0.023, rounded up to 0.025 for the CoG height's
        load-transfer error. (It was 0.04 with the mass counted, which does
        not enter ρ_x, and C_x's intervals were wider than its errors: 90 % coverage 1.00.)
    force_spread_scale : float
        Half-normal scale of the spread τ_d of the true force within a drive [-].
    abs_force_ratio, abs_force_ratio_sd : float
        Window-mean |ρ_x| of an ABS window as a fraction of μ_max, and its spread: ABS cycles
        the slip around the peak (about 0.5–1.5 peak slip), where the brush curve delivers
        0.9–1.0 μ and measured Magic Formula curves 0.9–1.0 μ (they fall slowly after the peak);
        0.97 ± 0.04, so 1.05 is two sds out.
    curve_shape_min, curve_bend_median, curve_bend_log_sd : float
        The shape exponent p of the ``"shaped"`` model is p_min + b with b log-normal (median,
        log-sd). p = 1 is the brush model; a measured Magic Formula curve (Pacejka 2006,
        205/60R15) is matched by p = 2.04 to 0.07 % of its slip below 70 % of the peak. p_min 0.5,
        median 1.2, log-sd 0.4: p between 1.1 and 2.8 with 90 %, median 1.7 — tyres are mostly
        Magic-Formula-like, and a brush-like curve lies in the prior's tail, not at a bound. C_x
        moves with p (a straighter start fits the same bending data with a lower C_x), so the
        prior's pull on p is a pull on C_x. On 30 + 30 one-hour drives
        (``benchmarks/results/shape_prior.json``) brush truth gave C_x −0.6 % (fitted p 1.06)
        and Magic Formula truth +1.2 % with this prior, −1.6 % (p 1.16) and +1.4 % with a prior
        bounded at p ≥ 1 (p − 1 log-normal, median 0.5, log-sd 1). p < 1 (bending before the
        brush) reads force noise as early bending without the deconvolved force density; with it
        it does not (skewed-force test windows, seeds 3-5: C_x −1.9 to −4.7 % with this prior,
        −1.1 to −4.2 % with p ≥ 1). Log-normal rather than half-normal: the sampler sees log b,
        whose prior tail is then Gaussian (with a half-normal NUTS did not converge on a
        one-hour drive: R-hat 1.021, a divergence).
    curve_shape_excess_log_mean, curve_shape_excess_log_sd : float
        Normal prior of log(C − 1), C the Magic Formula shape factor of the default ``"magic"``
        curve; and ``curve_curvature_log_mean``, ``curve_curvature_log_sd`` that of log(1 − E),
        E its curvature factor. The spread of the 9 distinct car/SUV sets of the shipped tyre
        database (:func:`~tyrebayes.inference.tyre.curve_prior.curve_shape_prior`, sds widened by
        √(1 + 1/9)): C 1.32-1.84 and E −4.1-0.63 among them, 90 % prior intervals C 1.33-1.87
        and E −2.3-0.72. At 30 % of the peak these tyres' secant slope is 0.97-1.02 of the slope
        at zero (the brush's 0.89), so a drive that stays there carries that range into C_x.
    force_noise_log_sd, slip_noise_log_sd : float
        Log-scale sds of λ_ρ and λ_σ, the scales on the stated force and slip noise (median 1:
        the stream states the noise it measured).
    slip_drift_median, slip_drift_log_sd : float
        Log-normal prior of τ, the sd of the slip offset each block of
        :data:`~tyrebayes.inference.tyre.data.BLOCK_S` seconds adds to its drive's offset [-].
        Slow slip errors come from rolling radii that drift with tyre temperature and pressure
        (0.05-0.1 % of radius over minutes: 5e-4-1e-3 of slip) and from slow force errors that
        the slip regression reads as slip (an IMU bias wandering by 0.1-0.2 m/s², road grade
        the features did not remove: 0.01-0.03 of ρ_x, 2e-4-6e-4 of slip at C_x = 50); a median
        of 3e-4 puts 90 % between 6e-5 and 1.6e-3; 0 leaves the blocks out. On the 16 external
        drives the blocks took C_x from +2.4 % (90 % coverage 14 of 16, 10 drives flagged for
        correlated slip errors) to +1.4 % (15 of 16, 2 flagged); on the
        package's own simulator they did not help (``benchmarks/results/block_offsets.json``,
        6 twenty-minute drives with ABS: C_x RMSE 6.1 % with them, 3.8 % without; one drive
        whose slip errors drift, variance inflation 6.9, +12.7 % against +3.0 %): within 5 s
        that drive's slip and force do not follow the curve, and why has not been found.

    Examples
    --------
    >>> priors = TyrePriors()
    >>> TyrePriors(c_xr_median=2 * priors.c_xr_median).c_xr_median > priors.c_xr_median
    True
    """

    c_xr_median: float = 35.0
    c_xr_log_sd: float = 0.45
    temp_sensitivity_mean: float = 0.008
    temp_sensitivity_sd: float = 0.006
    load_sensitivity_mean: float = 0.263
    load_sensitivity_sd: float = 0.0
    slip_offset_sd: float = 0.004
    force_gain_log_sd: float = 0.025
    force_spread_scale: float = 0.3
    abs_force_ratio: float = 0.97
    abs_force_ratio_sd: float = 0.04
    curve_shape_min: float = 0.5
    curve_bend_median: float = 1.2
    curve_bend_log_sd: float = 0.4
    curve_shape_excess_log_mean: float = -0.625
    curve_shape_excess_log_sd: float = 0.292
    curve_curvature_log_mean: float = -0.006
    curve_curvature_log_sd: float = 0.768
    force_noise_log_sd: float = 0.5
    slip_noise_log_sd: float = 0.3
    slip_drift_median: float = 3e-4
    slip_drift_log_sd: float = 1.0

    @property
    def load_sensitive(self) -> bool:
        """Whether the model has a load sensitivity q (``load_sensitivity_sd > 0``)."""
        return self.load_sensitivity_sd > 0

    def with_load_sensitivity(self) -> TyrePriors:
        """These priors with q's prior the measured tyres' spread, Normal(0.263, 0.246)."""
        return eqx.tree_at(
            lambda p: (p.load_sensitivity_mean, p.load_sensitivity_sd),
            self,
            MEASURED_LOAD_SENSITIVITY,
        )

    def mu_median(self, surfaces: tuple[str, ...]) -> jax.Array:
        return jnp.array([MU_MEDIAN[s] for s in surfaces])

    def mu_log_sd(self, surfaces: tuple[str, ...]) -> jax.Array:
        """Log-scale prior sd of μ_max on each surface (``surface_friction.MU_LOG_SD``)."""
        return jnp.array([MU_LOG_SD[s] for s in surfaces])


MODEL_KINDS = ("magic", "shaped", "brush", "linear")
# The Magic Formula curve with its shape and curvature drawn from the measured tyres'
# (tyre_curve_prior.py): no single shape, and none that bends as early as the brush
# (benchmarks/results/external_drives.json compares the kinds on drives the package did not make).
DEFAULT_KIND = "magic"


def check_kind(kind: str) -> None:
    """Raise ValueError unless ``kind`` is one of :data:`MODEL_KINDS`."""
    if kind not in MODEL_KINDS:
        raise ValueError(f"tyre model kind: expected one of {MODEL_KINDS}, got {kind!r}")


def _slip_and_slope(kind: str, rho, c_x, mu, params: dict):
    """Slip of a force in adhesion, f⁻¹(ρ), and its derivative dσ/dρ, elementwise.

    Forces at or beyond the peak map to the peak slip (zero derivative): a μ below the measured
    forces then cannot fit their slips, which is how the slip windows bound μ from below.
    ``params`` holds the curve's shape sites of ``kind`` (``curve_shape_c``, ``curve_curvature_e``
    for ``"magic"``, ``curve_shape`` for ``"shaped"``).
    """
    if kind == "linear":
        return rho / c_x, jnp.broadcast_to(1.0 / c_x, jnp.shape(rho))
    if kind == "magic":
        return magic_formula_inverse_and_slope(
            rho, c_x, mu, params["curve_shape_c"], params["curve_curvature_e"]
        )
    if kind == "shaped":
        return shaped_longitudinal_inverse_and_slope(rho, c_x, mu, params["curve_shape"])
    return brush_longitudinal_inverse_and_slope(rho, c_x, mu)


def curve_slip(kind: str, rho, c_x, mu, params: dict):
    """Slip of the fitted curve at force ρ in adhesion [-] (``params`` as :func:`_slip_and_slope`).

    Broadcasts over posterior draws: ``c_x``, ``mu`` and the shape entries of ``params`` may be
    arrays of draws.
    """
    return _slip_and_slope(kind, jnp.asarray(rho), jnp.asarray(c_x), jnp.asarray(mu), params)[0]


def tyre_model(
    obs: TyreObservations,
    priors: TyrePriors | None = None,
    kind: str = DEFAULT_KIND,
    observed: bool = True,
):
    """NumPyro model of one tyre set's windows (see the module docstring).

    Parameters
    ----------
    obs : TyreObservations
        Window-averaged observations (possibly several drives and surfaces).
    priors : TyrePriors, optional
        Prior scales (default :class:`TyrePriors`).
    kind : {"shaped", "brush", "linear"}
        Mean model: the brush model identifies μ_max where the data reach the nonlinear region;
        ``"shaped"`` (the default) adds the curve's shape exponent p (``curve_shape``; p = 1 is
        the brush, :func:`~tyrebayes.physics.tyre.shaped_longitudinal_inverse_and_slope`) for
        tyres whose curve bends later than the brush's; the linear model is for drives that never
        leave the linear region.
    observed : bool
        Condition on the measured slip and force (True) or sample them (posterior predictive).
    """
    priors = TyrePriors() if priors is None else priors
    check_kind(kind)
    n_drives, n_surfaces = obs.n_drives, obs.n_surfaces

    c_xr = numpyro.sample("c_xr", dist.LogNormal(jnp.log(priors.c_xr_median), priors.c_xr_log_sd))
    kappa = numpyro.sample(
        "temp_sensitivity", dist.Normal(priors.temp_sensitivity_mean, priors.temp_sensitivity_sd)
    )
    with numpyro.plate("surface", n_surfaces):
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
    curve = {}
    if kind == "magic":
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
    if kind == "shaped":
        bend = numpyro.sample(
            "curve_bend",
            dist.LogNormal(jnp.log(priors.curve_bend_median), priors.curve_bend_log_sd),
        )
        curve["curve_shape"] = numpyro.deterministic("curve_shape", priors.curve_shape_min + bend)
    rho_noise_scale = numpyro.sample(
        "rho_noise_scale", dist.LogNormal(0.0, priors.force_noise_log_sd)
    )
    # The stated slip noise is a local estimate of coloured noise; its scale is inferred.
    slip_noise_scale = numpyro.sample(
        "slip_noise_scale", dist.LogNormal(0.0, priors.slip_noise_log_sd)
    )
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

    weights = obs.mask.astype(obs.temperature_c.dtype)
    mean_temperature = jnp.sum(weights * obs.temperature_c) / jnp.maximum(jnp.sum(weights), 1.0)
    numpyro.deterministic("c_x", stiffness_with_sensitivity(c_xr, mean_temperature, kappa))

    params = dict(
        c_xr=c_xr,
        temp_sensitivity=kappa,
        mu_max=mu,
        abs_force_ratio=abs_ratio,
        **curve,
        rho_noise_scale=rho_noise_scale,
        slip_noise_scale=slip_noise_scale,
        slip_offset=slip_offset,
        force_gain=force_gain,
        force_level=force_level,
        force_spread=force_spread,
    )
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
    lik = window_likelihood(params, obs, kind)
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


class WindowLikelihood(NamedTuple):
    """Per-window likelihood of :func:`tyre_model` given its parameters.

    ``slip_loc``, ``slip_scale``: Normal of the measured slip (slip windows); ``rho_loc``,
    ``rho_scale``: Normal of the measured force (all windows); ``below_peak``: the log of the
    probability that a slip window's true force lies under μ_max (0 for ABS and padding);
    ``block_offset``: each slip window's block offset given its block's residuals (its
    conditional mean; 0 elsewhere), which ``slip_loc`` leaves out; ``block_log_correction``: what
    integrating the block offsets out adds to the slip log-likelihood (a scalar).
    """

    slip_loc: jax.Array
    slip_scale: jax.Array
    rho_loc: jax.Array
    rho_scale: jax.Array
    below_peak: jax.Array
    block_offset: jax.Array
    block_log_correction: jax.Array


def block_offsets(
    residual: jax.Array, precision: jax.Array, block_index: jax.Array, drift_sd: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """Integrate out one Normal(0, τ²) slip offset per block from Normal slip residuals.

    With window precisions p_i (0 for windows that do not count) and residuals r_i, a block with
    P = Σ p_i and Q = Σ p_i r_i has marginal log-likelihood Σ log N(r_i; 0, 1/p_i)
    − ½ log(1 + τ²P) + ½ τ²Q²/(1 + τ²P) (Sherman-Morrison on the block's covariance
    diag(1/p) + τ²11ᵀ): exact, and O(n). Returns (the correction, summed over blocks; the
    conditional mean τ²Q/(1 + τ²P) of each window's block offset).
    """
    n = residual.shape[0]
    total_precision = jax.ops.segment_sum(precision, block_index, num_segments=n)
    total_weighted = jax.ops.segment_sum(precision * residual, block_index, num_segments=n)
    tau2 = drift_sd**2
    denominator = 1.0 + tau2 * total_precision
    correction = jnp.sum(-0.5 * jnp.log(denominator) + 0.5 * tau2 * total_weighted**2 / denominator)
    offset = (tau2 * total_weighted / denominator)[block_index]
    return correction, jnp.where(precision > 0, offset, 0.0)


def _per_window(site: jax.Array, index: jax.Array, n: int) -> jax.Array:
    """``site[index]``; with one drive or surface (``n``, static) a broadcast of its only value,
    whose derivatives XLA computes without the scatter-adds a gather's transpose takes."""
    if n == 1:
        return jnp.broadcast_to(jnp.reshape(site, (-1,))[0], index.shape)
    return site[index]


class WindowQuantities(NamedTuple):
    """What the parameters set in each window, before any observation is compared with them.

    The likelihood is a fixed function of these (:func:`likelihood_of_quantities`), so a
    curvature can be built from their first derivatives alone (the online filter's
    Gauss-Newton curvature, :mod:`tyrebayes.inference.online.block_likelihood`).

    ``slip_loc``, ``slip_scale``: Normal of the measured slip (slip windows, before the block
    offset); ``rho_loc``, ``rho_scale``: Normal of the measured force; ``headroom``: the true
    force's distance below μ_max in its sds (slip windows); ``drift_sd``: the block offsets' sd τ
    (a scalar; 0 without them).
    """

    slip_loc: jax.Array
    slip_scale: jax.Array
    rho_loc: jax.Array
    rho_scale: jax.Array
    headroom: jax.Array
    drift_sd: jax.Array


def window_quantities(params: dict, obs: TyreObservations, kind: str) -> WindowQuantities:
    """The per-window quantities of :func:`window_likelihood` (``params`` as there)."""

    def per_drive(site):
        return _per_window(site, obs.drive_index, obs.n_drives)

    gain, level, spread = (
        per_drive(params[k]) for k in ("force_gain", "force_level", "force_spread")
    )
    rho_noise = params["rho_noise_scale"] * obs.rho_sd
    # The true force given its measurement, by Tweedie's formula on the density of the measured
    # forces (force_density.force_density_score): exact for Gaussian noise whatever the shape of
    # the force distribution. ρ_obs/g has noise η/g and score g·s(ρ_obs), so the gain just
    # divides. The variance factor is clipped to [0.05, 1]: with λ_ρ > 1 a single component's
    # factor 1 − λ²η²/(τ² + η²) can fall below zero. The upper bound dates from the kernel
    # estimate (raising it to 5 moved C_x by 0.3-0.5 points on one drive, then); between mixture
    # components the factor can exceed 1, and that is not re-measured.
    noise2 = rho_noise**2
    rho_hat = (obs.rho + noise2 * obs.rho_score) / gain
    rho_var = noise2 / gain**2 * jnp.clip(1.0 + noise2 * obs.rho_score_slope, 0.05, 1.0)
    c_x = stiffness_with_sensitivity(params["c_xr"], obs.temperature_c, params["temp_sensitivity"])
    if "load_sensitivity" in params:
        c_x = c_x * jnp.exp(params["load_sensitivity"] * obs.load_change)
    mu_window = _per_window(params["mu_max"], obs.surface_index, obs.n_surfaces)
    slip, slip_slope = _slip_and_slope(kind, rho_hat, c_x, mu_window, params)
    slip_scale = jnp.sqrt((params["slip_noise_scale"] * obs.slip_sd) ** 2 + slip_slope**2 * rho_var)

    # ABS windows: the total force sits near the peak, the slip is not measurable.
    limit_mean = -gain * params["abs_force_ratio"] * mu_window
    # Window-to-window spread of ABS cycling around the shared ratio: ~2 % of μ.
    limit_scale = jnp.sqrt(noise2 + (0.02 * mu_window) ** 2)
    # Outside ABS the force is quasi-static and below the peak: the true force of every slip
    # window lies under μ. Without this the inverse, which maps forces beyond the peak to the
    # peak slip, would let a μ_max below the measured forces fit (a spurious mode: μ ~0.25 and
    # C_x twice the truth).
    headroom = (mu_window - jnp.abs(rho_hat)) / jnp.sqrt(rho_var + (0.02 * mu_window) ** 2)
    return WindowQuantities(
        slip_loc=slip + per_drive(params["slip_offset"]),
        slip_scale=slip_scale,
        rho_loc=jnp.where(obs.at_limit, limit_mean, gain * level),
        rho_scale=jnp.where(obs.at_limit, limit_scale, jnp.sqrt((gain * spread) ** 2 + noise2)),
        headroom=headroom,
        drift_sd=params.get("slip_drift_sd", jnp.zeros((), slip.dtype)),
    )


def likelihood_of_quantities(q: WindowQuantities, obs: TyreObservations) -> WindowLikelihood:
    """The windows' likelihood terms given their quantities (:func:`window_likelihood`)."""
    slip_window = obs.mask & ~obs.at_limit
    below_peak = jnp.where(slip_window, jax.scipy.special.log_ndtr(q.headroom), 0.0)
    precision = jnp.where(slip_window, obs.slip_weight / q.slip_scale**2, 0.0).astype(
        q.slip_loc.dtype
    )
    correction, offset = block_offsets(
        jnp.where(precision > 0, obs.slip - q.slip_loc, 0.0),
        precision,
        obs.block_index,
        q.drift_sd,
    )
    return WindowLikelihood(
        slip_loc=q.slip_loc,
        slip_scale=q.slip_scale,
        rho_loc=q.rho_loc,
        rho_scale=q.rho_scale,
        below_peak=below_peak,
        block_offset=offset,
        block_log_correction=correction,
    )


def window_likelihood(params: dict, obs: TyreObservations, kind: str) -> WindowLikelihood:
    """The windows' likelihood terms of :func:`tyre_model` (see the module docstring).

    ``params`` holds the model's sampled sites by name (``c_xr``, ``temp_sensitivity``,
    ``mu_max``, ``abs_force_ratio``, ``rho_noise_scale``, ``slip_noise_scale``, ``slip_drift_sd``
    and ``load_sensitivity`` where the priors have them, the curve's shape sites of ``kind`` and
    the per-drive ``slip_offset``, ``force_gain``, ``force_level``, ``force_spread``); other keys
    are ignored, so a posterior draw can be passed as it is. The model and the posterior
    predictive share it.
    """
    return likelihood_of_quantities(window_quantities(params, obs, kind), obs)


__all__ = [
    "DEFAULT_KIND",
    "MEASURED_LOAD_SENSITIVITY",
    "MODEL_KINDS",
    "check_kind",
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
