"""The lateral model: per-axle cornering stiffness, μ_y and the nuisances of a real car.

Single-track (bicycle) dynamics, written as two measurement equations that need no lateral
velocity (which no production car measures). With the measured lateral acceleration corrected
for the sensor's roll and offset, a = (a_y,meas − b)/G, the axle forces over the static axle
loads are (thesis eq. 4.22/4.23 solved for the forces, normalised as eq. 5.5)

    ρ_f = a/g + J_z ṙ/(m g l_r),        ρ_r = a/g − J_z ṙ/(m g l_f),

and each axle's slip angle is the tyre curve's inverse, α = f⁻¹(ρ; c_y, μ_y, C, E) (the Magic
Formula of :func:`~tyrebayes.physics.tyre.magic_formula_inverse_and_slope`, slope c_y at zero,
peak μ_y). Each axle has its own shape C and curvature E (the ``axle_shapes`` effect): an
axle's curve is its two tyres' sum under the load transfer of its share of the roll stiffness,
and their tyres and loads may differ. With one shape for both, the axle whose curve bends
earlier pulls the other's slope (``tests/inference/lateral/test_fit.py``: a simulated car whose
rear curve is the rounder one). Then

1. **steering**: α_f − α_r = δ − L r/V_x (the lateral velocity cancels), with the road-wheel
   angle δ = (δ_sw − δ_0)/i_s. In steady cornering ṙ = 0 and this is δ = L/R + K a_y: only the
   understeer gradient K = (1/c_f − 1/c_r)/g is seen. Yaw transients (ṙ ≠ 0) load the axles
   differently and, with J_z, separate them.
2. **lateral kinematics**: a = V_x r + v̇_y − g sin φ_bank with v_y = l_r r − V_x α_r (the rear
   axle's slip angle gives the lateral velocity), so a_y,meas = G (V_x r + l_r ṙ − d(V_x α_r)/dt)
   + b + ε. This is what fixes the roll gain G (a body-fixed sensor that rolls by k_φ a reads
   a (1 + g k_φ)) and, in transients, the rear axle alone. Road bank is in ε. The slip angle
   α_r comes from the measured a_y, so its derivative carries a_y's noise; the residual is the
   equation's error filtered by the rear axle's sideslip lag, which takes that noise out again
   (output error, :func:`~.sideslip_lag.sideslip_lag`).

Nuisances: the steering ratio i_s (prior centred on the vehicle file's, not fixed), the
steering-wheel offset δ_0, the a_y offset b, the roll gradient k_φ, the yaw inertia J_z (prior
±15 % about the vehicle file's), the noise scales of both equations and of the axle forces,
which reach the steering equation through the curve's slope (:func:`log_likelihoods`). The
tyres' relaxation length can be added (:meth:`LateralPriors.adding`); :data:`DEFAULT_EFFECTS`
says why it is not there by default.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpyro
import numpyro.distributions as dist

from ...physics.tyre import magic_formula_inverse_and_slope
from ..surface_friction import MU_LOG_SD, MU_MEDIAN
from .data import CorneringObservations, G
from .sideslip_lag import compact_p, compact_q, sideslip_lag

#: The nuisance effects the model knows: the a_y sensor's roll gain and offset, the steering
#: angle offset, the tyres' relaxation length, the yaw inertia's uncertainty and a curve shape
#: per axle (left out, the front's curve shape serves both axles).
LATERAL_EFFECTS = (
    "roll",
    "ay_offset",
    "steering_offset",
    "relaxation",
    "yaw_inertia",
    "axle_shapes",
)
#: The effects a fit carries by default. The relaxation length is left out: its ELPD gain is
#: within two SEs on every external cornering drive and real log, and with it the mean of the
#: external drives' c_y and K errors grows (``benchmarks/results/lateral_effects.json``); a
#: car's relaxation lag at 10 Hz is below what the data resolve. The per-axle curve shapes are
#: in: their ELPD gain is found on the two real logs there, and on the external drives they
#: bring the understeer gradient's error down.
DEFAULT_EFFECTS = ("roll", "ay_offset", "steering_offset", "yaw_inertia", "axle_shapes")
#: Each effect's value where it is left out (``axle_shapes``: the rear takes the front's shape).
NULL_VALUES = {
    "roll_gradient": 0.0,
    "ay_offset": 0.0,
    "steering_offset": 0.0,
    "relaxation_length": 0.0,
    "yaw_inertia_factor": 1.0,
}
#: The sample sites of each effect.
EFFECT_SITES = {
    "roll": ("roll_gradient",),
    "ay_offset": ("ay_offset",),
    "steering_offset": ("steering_offset",),
    "relaxation": ("relaxation_length",),
    "yaw_inertia": ("yaw_inertia_factor",),
    "axle_shapes": ("curve_shape_excess_rear", "curve_curvature_gap_rear"),
}
#: The model's sample sites, in the order of the fitters' flat parameter vectors (the batch fit's
#: and the in-car estimator's).
SAMPLE_SITES = (
    "c_y_front",
    "c_y_rear",
    "mu_y",
    "steering_ratio",
    "steering_offset",
    "ay_offset",
    "roll_gradient",
    "yaw_inertia_factor",
    "relaxation_length",
    "curve_shape_excess_front",
    "curve_shape_excess_rear",
    "curve_curvature_gap_front",
    "curve_curvature_gap_rear",
    "steer_noise",
    "kinematic_noise",
    "force_noise",
)
#: Sample sites on the real line; every other is positive and carried as its logarithm.
REAL_SITES = ("steering_offset", "ay_offset")


def sample_sites(priors: LateralPriors, *, road_wheel: bool = False) -> tuple[str, ...]:
    """The sample sites of ``priors``' effects, in :data:`SAMPLE_SITES` order.

    With ``road_wheel`` (the log gives the road-wheel angle) the steering ratio is left out:
    nothing reads it.

    Examples
    --------
    >>> sample_sites(LateralPriors())[:3]
    ('c_y_front', 'c_y_rear', 'mu_y')
    >>> "steering_ratio" in sample_sites(LateralPriors(), road_wheel=True)
    False
    """
    left_out = {n for e in LATERAL_EFFECTS if e not in priors.effects for n in EFFECT_SITES[e]}
    if road_wheel:
        left_out.add("steering_ratio")
    return tuple(n for n in SAMPLE_SITES if n not in left_out)


class LateralPriors(eqx.Module):
    """Prior scales of the lateral model.

    Attributes
    ----------
    c_y_median, c_y_log_sd : float
        Per-axle cornering stiffness over static axle load [1/rad]: median and log-sd. The
        median is the measured car and SUV tyres' K_y/F_z at nominal load (16.5,
        ``models/tyre_curves/mf_lateral_sets.csv``, 8 sets); the log-sd 0.5 is three times
        theirs (0.16): an axle's value includes compliance steer, load and pressure.
    steering_ratio_log_sd : float
        Of the steering ratio about the vehicle file's value [-]: real racks differ from the
        nominal ratio by a few percent and vary with angle.
    steering_offset_sd_rad : float
        Steering-wheel angle offset [rad] (about 3°).
    ay_offset_sd : float
        a_y sensor offset [m/s²].
    roll_gradient_median, roll_gradient_log_sd : float
        Body roll per unit lateral acceleration [rad/(m/s²)]: 0.006 is 3.5°/g, passenger cars
        roll 2-7°/g.
    yaw_inertia_log_sd : float
        Of J_z about the vehicle file's value: rarely measured, often m·l_f·l_r.
    curve_shape_excess_log_mean, curve_shape_excess_log_sd : float
        Magic Formula shape C = 1 + exp(N(mean, sd)) of each axle, independently: the measured
        tyres' C − 1 has median 0.344 and log-sd 0.268
        (``models/tyre_curves/derive_lateral_prior.py``).
    curve_curvature_gap_log_mean, curve_curvature_gap_log_sd : float
        Curvature E = 1 − exp(N(mean, sd)) (E < 1) of each axle: the measured tyres' E has mean
        −0.63 and sd 0.47, i.e. 1 − E ≈ 1.63 (log 0.489) with log-sd 0.47/1.63.
    relaxation_length_median_m, relaxation_length_log_sd : float
        The tyres' lateral relaxation length σ [m] (car tyres 0.3-1 m, longer at low load).
    effects : tuple of str
        The nuisance effects in the model (:data:`LATERAL_EFFECTS`); one left out is fixed at
        its null value (no roll, no offset, no relaxation, the vehicle file's J_z). The model
        criticism benchmark leaves each out in turn.
    peak_margin : float
        How far above μ_y a measured axle force may lie as noise [-]: an axle cannot give more
        than its peak, so a μ_y below the measured forces is penalised (half-normal beyond it).
    steer_noise_median, kinematic_noise_median : float
        Medians of the noise scales of the two equations [rad], [m/s²] (log-sd 1).
    force_noise_median : float
        Median of the noise of the axle forces ρ [-] (log-sd 1), which reaches the steering
        equation through the curve's slope dα/dρ.

    Examples
    --------
    >>> priors = LateralPriors()
    >>> priors.c_y_median, priors.effects
    (16.5, ('roll', 'ay_offset', 'steering_offset', 'yaw_inertia', 'axle_shapes'))
    >>> LateralPriors(c_y_median=20.0).c_y_median
    20.0
    """

    c_y_median: float = 16.5
    c_y_log_sd: float = 0.5
    steering_ratio_log_sd: float = 0.05
    steering_offset_sd_rad: float = 0.05
    ay_offset_sd: float = 0.3
    roll_gradient_median: float = 0.006
    roll_gradient_log_sd: float = 0.5
    yaw_inertia_log_sd: float = 0.15
    curve_shape_excess_log_mean: float = -1.066
    curve_shape_excess_log_sd: float = 0.268
    curve_curvature_gap_log_mean: float = 0.489
    curve_curvature_gap_log_sd: float = 0.29
    peak_margin: float = 0.02
    relaxation_length_median_m: float = 0.5
    relaxation_length_log_sd: float = 0.7
    steer_noise_median: float = 1e-3
    kinematic_noise_median: float = 0.2
    force_noise_median: float = 0.01
    effects: tuple[str, ...] = eqx.field(static=True, default=DEFAULT_EFFECTS)

    def __check_init__(self):
        unknown = set(self.effects) - set(LATERAL_EFFECTS)
        if unknown:
            raise ValueError(
                f"LateralPriors.effects: expected a subset of {LATERAL_EFFECTS}, "
                f"got {sorted(unknown)}"
            )

    def without(self, effect: str) -> LateralPriors:
        """These priors with one effect left out of the model (fixed at its null value)."""
        if effect not in LATERAL_EFFECTS:
            raise ValueError(f"effect: expected one of {LATERAL_EFFECTS}, got {effect!r}")
        return dataclasses.replace(self, effects=tuple(e for e in self.effects if e != effect))

    def adding(self, effect: str) -> LateralPriors:
        """These priors with one more effect in the model."""
        if effect not in LATERAL_EFFECTS:
            raise ValueError(f"effect: expected one of {LATERAL_EFFECTS}, got {effect!r}")
        return dataclasses.replace(self, effects=tuple(dict.fromkeys((*self.effects, effect))))

    def mu_y_prior(self, surface: str) -> tuple[float, float]:
        """Median and log-sd of μ_y on ``surface`` (the longitudinal μ_max prior's)."""
        if surface not in MU_MEDIAN:
            raise ValueError(f"surface: expected one of {tuple(MU_MEDIAN)}, got {surface!r}")
        return MU_MEDIAN[surface], MU_LOG_SD[surface]


def derivative(x: jnp.ndarray, dt: float | jnp.ndarray) -> jnp.ndarray:
    """d/dt of a sampled signal: the five-point central stencil, second-order at the ends.

    The observations are decimated to 10 Hz; there a three-point difference already reads a
    1 Hz yaw transient's derivative 6.5 % low, which the transient equations would turn into a
    biased split of front and rear. The five-point stencil's error there is 0.5 %.
    """
    d3 = jnp.gradient(x, dt)
    d5 = (x[:-4] - 8.0 * x[1:-3] + 8.0 * x[3:-1] - x[4:]) / (12.0 * dt)
    return d3.at[2:-2].set(d5)


class AxleState(eqx.Module):
    """Per-sample axle loads and slip angles at one parameter point."""

    rho_front: jnp.ndarray
    rho_rear: jnp.ndarray
    alpha_front: jnp.ndarray
    alpha_rear: jnp.ndarray
    ay_true: jnp.ndarray
    slope_front: jnp.ndarray
    slope_rear: jnp.ndarray


def axle_state(obs: CorneringObservations, p: dict) -> AxleState:
    """ρ and α per axle at the parameters ``p`` (module docstring; effects missing from ``p``
    take their null values)."""
    p = {**NULL_VALUES, **p}
    m, lf, lr = obs.mass_kg, obs.cog_to_front_axle_m, obs.cog_to_rear_axle_m
    gain = 1.0 + G * p["roll_gradient"]
    a = (obs.ay - p["ay_offset"]) / gain
    jz = obs.yaw_inertia_kgm2 * p["yaw_inertia_factor"]
    rho_f = a / G + jz * obs.yaw_acceleration / (m * G * lr)
    rho_r = a / G - jz * obs.yaw_acceleration / (m * G * lf)
    # Relaxation: the force builds up over a rolling distance σ, τ dρ/dt + ρ = c α, so the slip
    # angle that geometry sees leads the force by τ = σ/V_x.
    tau = p["relaxation_length"] / obs.speed
    rho_f_lead = rho_f + tau * derivative(rho_f, obs.dt_s)
    rho_r_lead = rho_r + tau * derivative(rho_r, obs.dt_s)
    alpha_f, slope_f = magic_formula_inverse_and_slope(
        rho_f_lead,
        p["c_y_front"],
        p["mu_y"],
        1.0 + p["curve_shape_excess_front"],
        1.0 - p["curve_curvature_gap_front"],
    )
    alpha_r, slope_r = magic_formula_inverse_and_slope(
        rho_r_lead,
        p["c_y_rear"],
        p["mu_y"],
        1.0 + p.get("curve_shape_excess_rear", p["curve_shape_excess_front"]),
        1.0 - p.get("curve_curvature_gap_rear", p["curve_curvature_gap_front"]),
    )
    return AxleState(
        rho_f,
        rho_r,
        alpha_f,
        alpha_r,
        a,
        _slope_near_peak(slope_f, rho_f_lead, p["c_y_front"], p["mu_y"]),
        _slope_near_peak(slope_r, rho_r_lead, p["c_y_rear"], p["mu_y"]),
    )


#: dα/dρ is capped at this many times the linear range's 1/c_y: at and beyond the peak a slip
#: angle is not determined by the force at all, and its steering residual then carries the
#: largest variance the cap allows.
PEAK_SLOPE_CAP = 20.0


def _slope_near_peak(slope, rho, c_y, mu):
    """dα/dρ of the curve, capped (:data:`PEAK_SLOPE_CAP`); the cap at and beyond the peak."""
    cap = PEAK_SLOPE_CAP / c_y
    return jnp.minimum(jnp.where(jnp.abs(rho) < mu, slope, cap), cap)


def residuals(
    obs: CorneringObservations, p: dict, state: AxleState | None = None
) -> tuple[jnp.ndarray, jnp.ndarray]:
    """The two equations' residuals (steering [rad], kinematics [m/s²]) at ``p``.

    ``state`` is :func:`axle_state` at ``p`` where the caller has it already (the model
    reads it for the peak bound too: one evaluation of the curve's inverse serves all three).
    """
    p = {**NULL_VALUES, **p}
    s = axle_state(obs, p) if state is None else state
    ratio = 1.0 if obs.road_wheel else p["steering_ratio"]
    delta = (obs.steering - p["steering_offset"]) / ratio
    steer = delta - obs.wheelbase_m * obs.yaw_rate / obs.speed - (s.alpha_front - s.alpha_rear)
    gain = 1.0 + G * p["roll_gradient"]
    kinematic_rate = obs.speed * obs.yaw_rate + obs.cog_to_rear_axle_m * obs.yaw_acceleration
    # The equation error e = a_y − Γ(V_x r + l_r ṙ − D(V_x α_r)) − b, premultiplied by P.
    equation = compact_p(obs.ay - gain * kinematic_rate - p["ay_offset"])
    equation = equation + gain * compact_q(obs.speed * s.alpha_rear, obs.dt_s)
    # Λ: how fast the rear axle's sideslip V_x α_r settles, G (dρ_r/dα_r)/V_x.
    settling = G / (obs.speed * s.slope_rear)
    kinematic = sideslip_lag(equation[:, None], settling, obs.mask_kinematic, obs.dt_s)[:, 0]
    return steer, kinematic


def lateral_model(
    obs: CorneringObservations,
    priors: LateralPriors,
    mu_y_prior=None,
    weights=(1.0, 1.0),
    data_scale=1.0,
):
    """NumPyro model of one drive's cornering (module docstring).

    ``mu_y_prior`` is the median and log-sd of μ_y's prior (:meth:`LateralPriors.mu_y_prior`
    of the drive's surface; ``None``: dry). They are numbers the model reads, not a name it
    looks up, so that drives on every surface share one compiled program of the fit.

    ``weights`` are the two equations' likelihood weights, 1/VIF of their residuals'
    correlation between samples (:func:`.fit.residual_inflation`). ``data_scale`` multiplies
    every term of the data (both equations and the peak bound): a subset of a drive's samples
    scaled by the whole drive's count over the subset's has the whole drive's curvature, which
    is what the fit's search on a subset needs (:func:`.fit.search_stride`).
    """
    mu_median, mu_log_sd = priors.mu_y_prior("dry") if mu_y_prior is None else mu_y_prior
    p = {
        "c_y_front": numpyro.sample(
            "c_y_front", dist.LogNormal(jnp.log(priors.c_y_median), priors.c_y_log_sd)
        ),
        "c_y_rear": numpyro.sample(
            "c_y_rear", dist.LogNormal(jnp.log(priors.c_y_median), priors.c_y_log_sd)
        ),
        "mu_y": numpyro.sample("mu_y", dist.LogNormal(jnp.log(mu_median), mu_log_sd)),
    }
    for axle in ("front", "rear") if "axle_shapes" in priors.effects else ("front",):
        p[f"curve_shape_excess_{axle}"] = numpyro.sample(
            f"curve_shape_excess_{axle}",
            dist.LogNormal(priors.curve_shape_excess_log_mean, priors.curve_shape_excess_log_sd),
        )
        p[f"curve_curvature_gap_{axle}"] = numpyro.sample(
            f"curve_curvature_gap_{axle}",
            dist.LogNormal(priors.curve_curvature_gap_log_mean, priors.curve_curvature_gap_log_sd),
        )
    nuisance = {
        "steering_offset": dist.Normal(0.0, priors.steering_offset_sd_rad),
        "ay_offset": dist.Normal(0.0, priors.ay_offset_sd),
        "roll_gradient": dist.LogNormal(
            jnp.log(priors.roll_gradient_median), priors.roll_gradient_log_sd
        ),
        "relaxation_length": dist.LogNormal(
            jnp.log(priors.relaxation_length_median_m), priors.relaxation_length_log_sd
        ),
        "yaw_inertia_factor": dist.LogNormal(0.0, priors.yaw_inertia_log_sd),
    }
    included = {n for e in priors.effects for n in EFFECT_SITES[e]}
    for site, prior in nuisance.items():
        p[site] = numpyro.sample(site, prior) if site in included else NULL_VALUES[site]
    if not obs.road_wheel:
        p["steering_ratio"] = numpyro.sample(
            "steering_ratio",
            dist.LogNormal(jnp.log(obs.steering_ratio), priors.steering_ratio_log_sd),
        )
    steer_noise = numpyro.sample(
        "steer_noise", dist.LogNormal(jnp.log(priors.steer_noise_median), 1.0)
    )
    force_noise = numpyro.sample(
        "force_noise", dist.LogNormal(jnp.log(priors.force_noise_median), 1.0)
    )
    kinematic_noise = numpyro.sample(
        "kinematic_noise", dist.LogNormal(jnp.log(priors.kinematic_noise_median), 1.0)
    )
    numpyro.deterministic("understeer_gradient", (1.0 / p["c_y_front"] - 1.0 / p["c_y_rear"]) / G)
    p.update(steer_noise=steer_noise, kinematic_noise=kinematic_noise, force_noise=force_noise)
    state = axle_state(obs, p)
    beyond = jnp.maximum(
        jnp.maximum(jnp.abs(state.rho_front), jnp.abs(state.rho_rear)) - p["mu_y"], 0
    )
    numpyro.factor(
        "peak_bound",
        -0.5 * data_scale * jnp.sum(jnp.where(obs.mask, (beyond / priors.peak_margin) ** 2, 0.0)),
    )
    log_steer, log_kin = log_likelihoods(obs, p, state)
    numpyro.factor(
        "steering_equation",
        data_scale * weights[0] * jnp.sum(jnp.where(obs.mask, log_steer, 0.0)),
    )
    numpyro.factor(
        "kinematic_equation",
        data_scale * weights[1] * jnp.sum(jnp.where(obs.mask_kinematic, log_kin, 0.0)),
    )


def log_likelihoods(
    obs: CorneringObservations, p: dict, state: AxleState | None = None
) -> tuple[jnp.ndarray, jnp.ndarray]:
    """Each sample's log-likelihood under the steering and the kinematic equation at ``p``.

    Errors in variables: the axle forces come from measured a_y and ṙ, so each slip angle
    carries their noise through the curve's slope dα/dρ; near the peak that slope is steep and
    the sample says little (its effective variance is large). ``state``: as in
    :func:`residuals`.
    """
    state = axle_state(obs, p) if state is None else state
    steer, kinematic = residuals(obs, p, state)
    steer_sd = jnp.sqrt(
        p["steer_noise"] ** 2 + p["force_noise"] ** 2 * (state.slope_front**2 + state.slope_rear**2)
    )
    return (
        dist.Normal(0.0, steer_sd).log_prob(steer),
        dist.Normal(0.0, p["kinematic_noise"]).log_prob(kinematic),
    )
