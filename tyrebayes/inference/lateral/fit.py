"""Fitting the lateral model: MAP + Laplace (``"laplace"``) or NUTS (``"nuts"``), one result type.

The Laplace path minimises the NumPyro model's potential on its unconstrained space with
optimistix BFGS, takes the Hessian there and draws from N(mode, H⁻¹) through the model's
constraints. The residuals of both equations are correlated from sample to sample (the signals
are low-passed, and road bank and unmodelled dynamics vary slowly), so each equation's
likelihood is weighted by 1/VIF of its residuals at a first mode (:func:`residual_inflation`)
and the mode is found again: without it the intervals would count correlated samples as
independent and be several times too narrow.
"""

from __future__ import annotations

import functools
import json

import arviz_base as azb
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import xarray as xr
from numpyro.infer import MCMC, NUTS, init_to_value
from numpyro.infer.util import potential_energy

from ..result import Fit, diagnose, provenance
from .data import CorneringObservations, G
from .model import (
    EFFECT_SITES,
    LATERAL_EFFECTS,
    LateralPriors,
    axle_state,
    lateral_model,
    residuals,
)
from .result import LateralFit

#: The fitting methods (``"laplace"``: MAP + Laplace; ``"nuts"``: NUTS from the Laplace mode).
LATERAL_METHODS = ("laplace", "nuts")
#: μ_y counts as observed where an axle used this share of it (and the data narrowed it).
MU_Y_USE_OBSERVED = 0.8
#: ... and where its posterior log-sd is at most this share of the prior's.
MU_Y_CONTRACTION = 0.5
#: The understeer gradient counts as identified where its posterior sd is at most this share
#: of the prior's.
K_CONTRACTION = 0.5
_SITES = (
    "c_y_front",
    "c_y_rear",
    "understeer_gradient",
    "mu_y",
    "steering_ratio",
    "steering_offset",
    "ay_offset",
    "roll_gradient",
    "yaw_inertia_factor",
    "relaxation_length",
    "curve_shape_excess",
    "curve_curvature_gap",
    "steer_noise",
    "kinematic_noise",
    "force_noise",
)


def _site_names(road_wheel: bool, priors: LateralPriors) -> tuple[str, ...]:
    """The model's sample sites in the order of the flat parameter vector."""
    left_out = {EFFECT_SITES[e] for e in LATERAL_EFFECTS if e not in priors.effects}
    if road_wheel:
        left_out.add("steering_ratio")
    return tuple(n for n in _SITES if n != "understeer_gradient" and n not in left_out)


def _start(obs: CorneringObservations, priors: LateralPriors, surface: str) -> jnp.ndarray:
    """The unconstrained start: the priors' medians (log for the positive sites)."""
    mu, _ = priors.mu_y_prior(surface)
    values = {
        "c_y_front": np.log(priors.c_y_median),
        "c_y_rear": np.log(priors.c_y_median),
        "mu_y": np.log(mu),
        "curve_shape_excess": priors.curve_shape_excess_log_mean,
        "curve_curvature_gap": priors.curve_curvature_gap_log_mean,
        "steering_offset": 0.0,
        "ay_offset": 0.0,
        "roll_gradient": np.log(priors.roll_gradient_median),
        "yaw_inertia_factor": 0.0,
        "relaxation_length": np.log(priors.relaxation_length_median_m),
        "steer_noise": np.log(priors.steer_noise_median),
        "kinematic_noise": np.log(priors.kinematic_noise_median),
        "force_noise": np.log(priors.force_noise_median),
        "steering_ratio": float(np.log(obs.steering_ratio)),
    }
    names = _site_names(obs.road_wheel, priors)
    return jnp.asarray([values[n] for n in names], dtype=obs.ay.dtype)


def _potential(x, obs, weights, priors, surface):
    params = dict(zip(_site_names(obs.road_wheel, priors), x, strict=True))
    return potential_energy(lateral_model, (obs, priors, surface, weights), {}, params)


@functools.partial(jax.jit, static_argnames=("priors", "surface", "max_steps"))
def _mode(x0, obs, weights, priors, surface, max_steps):
    """BFGS mode of the potential, whether it converged, and the Hessian there.

    Compiled once per observation shape, priors and surface; the weights are data.
    """

    def f(x, _):
        return _potential(x, obs, weights, priors, surface)

    sol = optx.minimise(f, optx.BFGS(rtol=1e-8, atol=1e-8), x0, max_steps=max_steps, throw=False)
    return sol.value, sol.result == optx.RESULTS.successful, jax.hessian(f)(sol.value, None)


_potential_at = jax.jit(_potential, static_argnames=("priors", "surface"))


def _minimum(x0, obs, weights, priors, surface, max_steps, escapes: int = 3):
    """A local minimum of the potential (not a saddle): BFGS, then away from any saddle.

    BFGS stops where the gradient vanishes; near the tyre curve's peak (a drive that used most
    of μ_y) the potential has saddles, where the Hessian has a negative eigenvalue. From one,
    the search steps both ways along that eigenvector, by the distance at which a quadratic of
    that curvature would drop the potential by 2, and goes on from the lower side.
    Returns ``(mode, converged, hessian)``.
    """
    mode, ok, hess = _mode(x0, obs, weights, priors, surface, max_steps)
    for _ in range(escapes):
        sym = 0.5 * (np.asarray(hess) + np.asarray(hess).T)
        if not np.all(np.isfinite(sym)):
            break
        eig, vec = np.linalg.eigh(sym)
        if eig[0] > 0:
            break
        step = 2.0 / np.sqrt(abs(eig[0]))
        starts = [mode + sign * step * jnp.asarray(vec[:, 0]) for sign in (1.0, -1.0)]
        values = [float(_potential_at(x, obs, weights, priors, surface)) for x in starts]
        mode, ok, hess = _mode(
            starts[int(np.argmin(values))], obs, weights, priors, surface, max_steps
        )
    return mode, ok, hess


#: The sites on the real line (Normal priors); every other site is positive (LogNormal), its
#: unconstrained value the logarithm.
_REAL_SITES = ("steering_offset", "ay_offset")


def _constrain(xs, obs, weights, priors, surface) -> dict:
    """Constrained draws of unconstrained draws ``xs`` (draws × sites), K included.

    The model's transforms are known (exp for the LogNormal sites, identity for the Normal
    ones), so the draws are mapped directly, without running the model's likelihood once per
    draw. ``weights`` is unused; kept so that the signature follows the model's arguments.
    """
    del weights
    names = _site_names(obs.road_wheel, priors)
    xs = np.asarray(xs)
    out = {n: xs[:, i] if n in _REAL_SITES else np.exp(xs[:, i]) for i, n in enumerate(names)}
    out["understeer_gradient"] = (1.0 / out["c_y_front"] - 1.0 / out["c_y_rear"]) / G
    return out


@jax.jit
def _residuals_at(point: dict, obs):
    return residuals(obs, point)


@jax.jit
def _state_at(point: dict, obs):
    return axle_state(obs, point)


#: Batch lengths of the batch-means variance inflation [samples at 10 Hz]: 10 s, 30 s, 60 s.
INFLATION_BLOCKS = (100, 300, 600)
#: A batch length counts where the record holds at least this many batches.
MIN_BATCHES = 8


def residual_inflation(r: np.ndarray, mask: np.ndarray) -> float:
    """Variance inflation factor of residuals ``r`` on ``mask``: how many samples count as one.

    The largest of the AR(1) factor (1 + φ)/(1 − φ) and the batch-means factors (the variance of
    means of ``b`` consecutive samples against the variance of one sample, times ``b``, for each
    ``b`` of :data:`INFLATION_BLOCKS` with at least :data:`MIN_BATCHES` batches): the first sees
    the low-pass filter's correlation, the others the slow one of road bank and of a curve that
    misfits over a whole corner or a long bend, which AR(1) misses. At least 1.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> residual_inflation(rng.normal(size=20000), np.ones(20000, bool)) < 1.5
    True
    """
    x = r[mask] - np.mean(r[mask])
    var = float(np.mean(x**2))
    if var <= 0 or x.size < 20:
        return 1.0
    phi = float(np.mean(x[1:] * x[:-1]) / var)
    phi = min(max(phi, 0.0), 0.995)
    factors = [1.0, (1.0 + phi) / (1.0 - phi)]
    for block in INFLATION_BLOCKS:
        n_blocks = x.size // block
        if n_blocks >= MIN_BATCHES:
            means = x[: n_blocks * block].reshape(n_blocks, block).mean(axis=1)
            factors.append(block * float(np.var(means)) / var)
    return max(factors)


def _identification(
    priors: LateralPriors, surface: str, samples: dict, state, obs, seed: int
) -> tuple[bool, bool, float]:
    """(K identified, μ_y observed, peak use) of the posterior ``samples`` against the prior."""
    rng = np.random.default_rng(seed)
    c = np.exp(rng.normal(np.log(priors.c_y_median), priors.c_y_log_sd, (2, 4000)))
    k_prior_sd = float(np.std((1.0 / c[0] - 1.0 / c[1]) / G))
    identified = float(np.std(samples["understeer_gradient"])) <= K_CONTRACTION * k_prior_sd
    mask = np.asarray(obs.mask)
    rho = np.abs(np.r_[np.asarray(state.rho_front)[mask], np.asarray(state.rho_rear)[mask]])
    use = float(np.quantile(rho, 0.99) / np.mean(samples["mu_y"])) if rho.size else 0.0
    _, mu_log_sd = priors.mu_y_prior(surface)
    narrowed = float(np.std(np.log(samples["mu_y"]))) <= MU_Y_CONTRACTION * mu_log_sd
    return identified, bool(narrowed and use >= MU_Y_USE_OBSERVED), use


#: Samples of a drive kept in its fit for the report's slip-angle plot (thinned evenly).
PLOT_SAMPLES = 1500


def _partial_slips(obs: CorneringObservations, state, samples: dict) -> xr.Dataset:
    """Each axle's force against its slip angle as the data see it, at the posterior mean.

    No car measures a slip angle; the steering equation measures the difference
    α_f − α_r = δ − L r/V_x. Each axle's "data" slip angle is that measured difference with the
    other axle's model slip added back: points that scatter about the axle's fitted curve by the
    steering equation's misfit (a partial-residual plot).
    """
    point = {k: float(np.mean(v)) for k, v in samples.items() if np.ndim(v) == 2}
    ratio = 1.0 if obs.road_wheel else point["steering_ratio"]
    offset = point.get("steering_offset", 0.0)
    mask = np.asarray(obs.mask)
    measured = (np.asarray(obs.steering) - offset) / ratio - np.asarray(
        obs.wheelbase_m * obs.yaw_rate / obs.speed
    )
    keep = np.flatnonzero(mask)
    keep = keep[np.linspace(0, keep.size - 1, min(PLOT_SAMPLES, keep.size)).astype(int)]
    alpha_f, alpha_r = np.asarray(state.alpha_front), np.asarray(state.alpha_rear)
    return xr.Dataset(
        {
            "rho_front": ("sample", np.asarray(state.rho_front)[keep]),
            "rho_rear": ("sample", np.asarray(state.rho_rear)[keep]),
            "alpha_front_partial": ("sample", (measured + alpha_r)[keep]),
            "alpha_rear_partial": ("sample", (alpha_f - measured)[keep]),
        }
    )


def _mean_point(samples: dict) -> dict:
    return {k: jnp.asarray(np.mean(v, axis=0)) for k, v in samples.items()}


def _adequacy(obs: CorneringObservations, samples: dict, vif: tuple[float, float]) -> list[str]:
    """Reasons the model does not describe the drive: a trend of the steering residual with a_y.

    The residual's mean in eight a_y bins, each against its standard error (inflated by the
    residuals' correlation), should stay within ±4: a tyre curve or a steering model that
    does not fit shows as a systematic bend against a_y.
    """
    steer = np.asarray(_residuals_at(_mean_point(samples), obs)[0])
    mask = np.asarray(obs.mask)
    ay = np.asarray(obs.ay)[mask]
    r = steer[mask]
    if r.size < 80:
        return []
    edges = np.quantile(ay, np.linspace(0, 1, 9))
    idx = np.clip(np.searchsorted(edges, ay, side="right") - 1, 0, 7)
    sd = float(np.std(r))
    worst = 0.0
    for b in range(8):
        rb = r[idx == b]
        if rb.size >= 10:
            worst = max(worst, abs(float(np.mean(rb))) / (sd * np.sqrt(vif[0] / rb.size)))
    if worst > 4.0:
        return [f"steering residual bends with a_y ({worst:.1f} standard errors in one bin)"]
    return []


def _weighted_mode(obs, priors, surface, max_steps):
    """The mode with each equation weighted by 1/VIF of its residuals at the unweighted mode.

    Returns ``(mode, converged, hessian, weights, vif)``.
    """
    unit = jnp.ones(2, dtype=obs.ay.dtype)
    mode, _, _ = _minimum(_start(obs, priors, surface), obs, unit, priors, surface, max_steps)
    point = {k: v[0] for k, v in _constrain(mode[None], obs, unit, priors, surface).items()}
    steer, kin = (np.asarray(x) for x in _residuals_at(point, obs))
    vif = (
        residual_inflation(steer, np.asarray(obs.mask)),
        residual_inflation(kin, np.asarray(obs.mask_kinematic)),
    )
    weights = jnp.asarray([1.0 / vif[0], 1.0 / vif[1]], dtype=obs.ay.dtype)
    mode, ok, hess = _minimum(mode, obs, weights, priors, surface, max_steps)
    return mode, bool(ok), np.asarray(hess), weights, vif


def _covariance_root(hess: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """A square root S of H⁻¹ (S S' = H⁻¹), and the problems found in H.

    A Hessian that is not finite or not positive definite is a failed fit (said in its
    diagnostics); its draws then come from the Hessian with the non-positive directions given
    the unconstrained prior's unit scale, wide where the data say nothing.
    """
    hess = 0.5 * (hess + hess.T)
    problems = []
    if not np.all(np.isfinite(hess)):
        problems.append("Hessian at the mode is not finite")
        hess = np.eye(hess.shape[0])
    eig, vec = np.linalg.eigh(hess)
    if eig.min() <= 0:
        problems.append("Hessian at the mode is not positive definite")
        eig = np.where(eig > 0, eig, 1.0)
    return vec / np.sqrt(eig)[None, :], problems


def _nuts(obs, priors, surface, weights, init: dict, key, settings: tuple[int, int, int]):
    """NUTS draws (by chain) from ``init`` and the divergences: ``(samples, sample_stats)``."""
    num_chains, num_warmup, num_samples = settings
    kernel = NUTS(
        lateral_model,
        init_strategy=init_to_value(
            values={k: v for k, v in init.items() if k != "understeer_gradient"}
        ),
        dense_mass=True,
    )
    mcmc = MCMC(
        kernel,
        num_warmup=num_warmup,
        num_samples=num_samples,
        num_chains=num_chains,
        chain_method="sequential",
        progress_bar=False,
    )
    mcmc.run(key, obs, priors, surface, weights, extra_fields=("diverging",))
    samples = {k: np.asarray(v) for k, v in mcmc.get_samples(group_by_chain=True).items()}
    diverging = np.asarray(mcmc.get_extra_fields(group_by_chain=True)["diverging"])
    return samples, {"diverging": diverging}


def fit_lateral(
    obs: CorneringObservations,
    method: str = "laplace",
    *,
    priors: LateralPriors | None = None,
    surface: str = "dry",
    seed: int = 0,
    num_draws: int = 2000,
    num_chains: int = 2,
    num_warmup: int = 500,
    num_samples: int = 1000,
    max_steps: int = 3000,
    inputs: tuple[str, ...] = (),
) -> LateralFit:
    """Posterior of the per-axle cornering stiffness, understeer gradient, μ_y and nuisances.

    Parameters
    ----------
    obs : CorneringObservations
        From :func:`~tyrebayes.inference.lateral.data.cornering_observations`.
    method : {"laplace", "nuts"}
        MAP + Laplace (default; seconds), or NUTS started at the Laplace mode.
    priors : LateralPriors, optional
    surface : str
        Road surface: the centre of μ_y's prior.
    seed : int
        Randomness of the draws.
    num_draws : int
        Laplace draws.
    num_chains, num_warmup, num_samples : int
        NUTS settings.
    max_steps : int
        BFGS steps.
    inputs : tuple of str
        Where the data came from (the provenance).

    Returns
    -------
    LateralFit
        Not converged (optimiser failure, Hessian not positive definite, R-hat/ESS) and not
        adequate are said in its diagnostics, never raised.

    Examples
    --------
    >>> fit = fit_lateral(cornering_observations(frame, vehicle))  # doctest: +SKIP
    >>> fit.to_dict()["understeer_gradient"]["mean"]  # doctest: +SKIP
    """
    if method not in LATERAL_METHODS:
        raise ValueError(f"lateral fit method: expected one of {LATERAL_METHODS}, got {method!r}")
    priors = LateralPriors() if priors is None else priors
    key_draw, key_nuts = jax.random.split(jax.random.PRNGKey(seed))
    mode, ok, hess, weights, vif = _weighted_mode(obs, priors, surface, max_steps)
    chol, problems = _covariance_root(hess)
    if method == "laplace":
        z = np.asarray(jax.random.normal(key_draw, (num_draws, mode.shape[0]), dtype=mode.dtype))
        flat = np.asarray(mode)[None, :] + z @ chol.T
        draws = _constrain(jnp.asarray(flat), obs, weights, priors, surface)
        samples = {k: np.asarray(v)[None] for k, v in draws.items()}
        sample_stats = None
        optimiser = "successful" if ok else "BFGS did not converge"
    else:
        init = {k: v[0] for k, v in _constrain(mode[None], obs, weights, priors, surface).items()}
        samples, sample_stats = _nuts(
            obs, priors, surface, weights, init, key_nuts, (num_chains, num_warmup, num_samples)
        )
        optimiser = "n/a"
    names = [k for k in _SITES if k in samples]
    groups = {"posterior": {k: samples[k] for k in names}}
    if sample_stats is not None:
        groups["sample_stats"] = sample_stats
    data = azb.from_dict(groups)
    flat_samples = {k: v.reshape((-1,) + v.shape[2:]) for k, v in samples.items()}
    state = _state_at(_mean_point(flat_samples), obs)
    data["constant_data"] = xr.DataTree(_partial_slips(obs, state, samples))
    identified, mu_observed, use = _identification(priors, surface, flat_samples, state, obs, seed)
    diagnostics = diagnose(
        data,
        method=method,
        var_names=[n for n in names if n != "understeer_gradient"],
        optimiser_result=optimiser,
        problems=problems,
    ).with_adequacy(_adequacy(obs, flat_samples, vif))
    data.attrs["lateral_vif"] = json.dumps([float(v) for v in vif])
    result = LateralFit(
        fit=Fit(
            data=data,
            diagnostics=diagnostics,
            kind="lateral",
            provenance=provenance(
                method,
                "single_track_magic",
                inputs,
                surface=surface,
                seed=seed,
                road_wheel=obs.road_wheel,
            ),
        ),
        mu_y_observed=mu_observed,
        identified=identified,
        cornering_seconds=float(obs.cornering_seconds),
        peak_use=use,
        road_wheel=obs.road_wheel,
    )
    result.fit.data.attrs.update(result.attrs())
    return result
