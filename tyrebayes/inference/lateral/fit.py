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

import dataclasses
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
    REAL_SITES,
    SAMPLE_SITES,
    LateralPriors,
    axle_state,
    lateral_model,
    residuals,
    sample_sites,
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
#: The posterior's variables in the order of the fit's summary: the sample sites with the
#: understeer gradient (derived from the two stiffnesses) after them.
_SUMMARY_SITES = (*SAMPLE_SITES[:2], "understeer_gradient", *SAMPLE_SITES[2:])


def _site_names(road_wheel: bool, priors: LateralPriors) -> tuple[str, ...]:
    """The model's sample sites in the order of the flat parameter vector."""
    return sample_sites(priors, road_wheel=road_wheel)


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


def _potential(x, obs, weights, scale, priors, surface):
    params = dict(zip(_site_names(obs.road_wheel, priors), x, strict=True))
    return potential_energy(lateral_model, (obs, priors, surface, weights, scale), {}, params)


# BFGS works in whitened coordinates y, x = start + W y with W W' ≈ H⁻¹ (posterior sds), and
# stops when a step moves every one by less than BFGS_ATOL and the potential by less than
# about BFGS_RTOL·|f| (the tyre fit's tolerances, inference/tyre/laplace.py says why): 1e-4
# sds is far below the Laplace draws' Monte-Carlo error (1/√2000 = 0.022 sds).
BFGS_ATOL = 1e-4
BFGS_RTOL = 1e-8


@functools.partial(jax.jit, static_argnames=("priors", "surface", "max_steps"))
def _bfgs(x0, whiten, obs, weights, scale, priors, surface, max_steps):
    """BFGS minimum of the potential from ``x0`` in the coordinates ``whiten`` gives.

    Returns ``(mode, converged, steps)``. Compiled once per observation shape, priors and
    surface; the start, whitening, weights and data scale are data.
    """

    def f(y, _):
        return _potential(x0 + whiten @ y, obs, weights, scale, priors, surface)

    solver = optx.BFGS(rtol=BFGS_RTOL, atol=BFGS_ATOL)
    sol = optx.minimise(f, solver, jnp.zeros_like(x0), max_steps=max_steps, throw=False)
    return x0 + whiten @ sol.value, sol.result == optx.RESULTS.successful, sol.stats["num_steps"]


_potential_at = jax.jit(_potential, static_argnames=("priors", "surface"))
_hessian = jax.jit(jax.hessian(_potential), static_argnames=("priors", "surface"))


def _whitening(hess: np.ndarray) -> np.ndarray:
    """W = V |Λ|^(-1/2) of a Hessian (eigenvalues in absolute value, floored at 1).

    The posterior's curvatures differ by orders of magnitude between the directions the data
    fix (c_y, the noise scales) and those only the prior does; BFGS from the identity took
    hundreds of steps on a one-hour drive. In coordinates where the Hessian is
    the identity its first step is a Newton step. Away from the mode H need not be positive
    definite, hence the absolute value; the floor keeps directions of no curvature at the
    unconstrained prior's unit scale.
    """
    sym = 0.5 * (hess + hess.T)
    if not np.all(np.isfinite(sym)):
        return np.eye(sym.shape[0])
    eig, vec = np.linalg.eigh(sym)
    return vec / np.sqrt(np.maximum(np.abs(eig), 1.0))[None, :]


def _minimum(x0, obs, weights, scale, priors, surface, max_steps, hess0=None, escapes: int = 3):
    """A local minimum of the potential (not a saddle): whitened BFGS, then away from any saddle.

    The whitening is the Hessian at ``x0`` (or ``hess0``, one at a nearby point). BFGS stops
    where the gradient vanishes; near the tyre curve's peak (a drive that used most of μ_y) the
    potential has saddles, where the Hessian has a negative eigenvalue. From one, the search
    steps both ways along that eigenvector, by the distance at which a quadratic of that
    curvature would drop the potential by 2, and goes on from the lower side.
    Returns ``(mode, converged, hessian)``.
    """
    args = (obs, weights, scale, priors, surface)
    hess = np.asarray(_hessian(x0, *args)) if hess0 is None else hess0
    mode, ok, _ = _bfgs(x0, jnp.asarray(_whitening(hess)), *args, max_steps=max_steps)
    hess = np.asarray(_hessian(mode, *args))
    for _ in range(escapes):
        sym = 0.5 * (hess + hess.T)
        if not np.all(np.isfinite(sym)):
            break
        eig, vec = np.linalg.eigh(sym)
        if eig[0] > 0:
            break
        step = 2.0 / np.sqrt(abs(eig[0]))
        starts = [mode + sign * step * jnp.asarray(vec[:, 0]) for sign in (1.0, -1.0)]
        values = [float(_potential_at(x, *args)) for x in starts]
        mode, ok, _ = _bfgs(
            starts[int(np.argmin(values))],
            jnp.asarray(_whitening(hess)),
            *args,
            max_steps=max_steps,
        )
        hess = np.asarray(_hessian(mode, *args))
    return mode, bool(ok), hess


#: Observations are padded to SEARCH_BLOCK times one of these numbers of blocks times a power of
#: two (at most a quarter more samples), so that drives of any length share a few compiled
#: programs instead of compiling one each.
_PADDED_BLOCKS = (4, 5, 6, 7)
#: Length of the stretches of a drive the search keeps [samples at 10 Hz]: the kinematic
#: equation differentiates V_x α_r along time, so the search reads whole 5 s stretches (their
#: two samples at each end left out of the equations) rather than every n-th sample.
SEARCH_BLOCK = 50
#: Samples the search for the weighted mode reads, about: a drive of more than 1.5 times as many
#: is searched on every n-th stretch, and the search's optimum refined on all samples.
SEARCH_SAMPLES = 6000
#: Samples the first search for the unweighted mode reads, about (:func:`_weighted_mode`): from
#: the priors' medians it takes the most BFGS steps of the fit, here each a quarter as dear.
INFLATION_SEARCH_SAMPLES = 1500


def padded_length(n: int) -> int:
    """The length a fit pads ``n`` observations to: SEARCH_BLOCK × m × 2^k, m in 4..7.

    Examples
    --------
    >>> padded_length(36000), padded_length(2390)
    (38400, 2400)
    """
    blocks = -(-n // SEARCH_BLOCK)
    k = 0
    while True:
        for m in _PADDED_BLOCKS:
            if m << k >= blocks:
                return SEARCH_BLOCK * (m << k)
        k += 1


_SERIES = ("speed", "yaw_rate", "yaw_acceleration", "ay", "steering", "mask", "mask_kinematic")


def _padded(obs: CorneringObservations) -> CorneringObservations:
    """``obs`` padded to :func:`padded_length` with samples outside both masks."""
    n = obs.speed.shape[0]
    extra = padded_length(n) - n
    if extra == 0:
        return obs
    # Padding's speed stays away from zero: the equations divide by it before the mask applies.
    fill = {"speed": 10.0, "mask": False, "mask_kinematic": False}
    series = {
        name: jnp.concatenate(
            [getattr(obs, name), jnp.full(extra, fill.get(name, 0.0), getattr(obs, name).dtype)]
        )
        for name in _SERIES
    }
    return dataclasses.replace(obs, **series)


def _search_stride(n: int, samples: int | None = None) -> int:
    """Every how many stretches a search of about ``samples`` (default :data:`SEARCH_SAMPLES`)
    reads of ``n`` padded samples."""
    return max(1, round(n / (SEARCH_SAMPLES if samples is None else samples)))


def _search_subset(obs: CorneringObservations, stride: int) -> tuple[CorneringObservations, float]:
    """Every ``stride``-th stretch of ``obs`` and the data scale that gives it the whole's weight.

    The scale is the whole drive's used samples over the subset's, so that the subset's
    potential has the whole's curvature (its Hessian whitens the refinement on all samples).
    """
    if stride == 1:
        return obs, 1.0
    blocks = obs.speed.shape[0] // SEARCH_BLOCK
    inner = np.ones(SEARCH_BLOCK, bool)
    inner[:2] = inner[-2:] = False
    inner = jnp.asarray(np.tile(inner, -(-blocks // stride)))

    def take(x):
        return x.reshape(blocks, SEARCH_BLOCK)[::stride].reshape(-1)

    series = {name: take(getattr(obs, name)) for name in _SERIES}
    # Each stretch's ends: the five-point derivatives there would reach into the next stretch.
    series["mask"] = series["mask"] & inner
    series["mask_kinematic"] = series["mask_kinematic"] & inner
    subset = dataclasses.replace(obs, **series)
    scale = float(jnp.sum(obs.mask)) / max(float(jnp.sum(subset.mask)), 1.0)
    return subset, scale


#: The sites on the real line (Normal priors); every other site is positive (LogNormal), its
#: unconstrained value the logarithm.


def _constrain(xs, obs, weights, priors, surface) -> dict:
    """Constrained draws of unconstrained draws ``xs`` (draws × sites), K included.

    The model's transforms are known (exp for the LogNormal sites, identity for the Normal
    ones), so the draws are mapped directly, without running the model's likelihood once per
    draw. ``weights`` is unused; kept so that the signature follows the model's arguments.
    """
    del weights
    names = _site_names(obs.road_wheel, priors)
    xs = np.asarray(xs)
    out = {n: xs[:, i] if n in REAL_SITES else np.exp(xs[:, i]) for i, n in enumerate(names)}
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


def _levels(obs, x, strides, weights, priors, surface, max_steps):
    """The mode found on every ``strides[0]``-th stretch, refined on every ``strides[1]``-th...

    Each level starts at the last one's mode, whitened by its Hessian (the subsets' data are
    scaled to the whole drive's weight, so every level's Hessian has about the whole's
    curvature). Returns ``(mode, converged, hessian)`` of the last level.
    """
    hess = None
    for stride in dict.fromkeys(strides):
        subset, scale = _search_subset(obs, stride)
        scale = jnp.asarray(scale, dtype=obs.ay.dtype)
        x, ok, hess = _minimum(x, subset, weights, scale, priors, surface, max_steps, hess)
    return x, ok, hess


def _weighted_mode(obs, priors, surface, max_steps):
    """The mode with each equation weighted by 1/VIF of its residuals at the unweighted mode.

    A long drive's unweighted mode is searched on a sparse subset of it
    (:data:`INFLATION_SEARCH_SAMPLES`) and refined on a denser one (:data:`SEARCH_SAMPLES`),
    the data scaled to the whole's weight; the weighted mode is searched on the denser subset
    and refined on all samples. A drive of at most about 1.5 × :data:`SEARCH_SAMPLES` has both
    modes searched on all its samples from the priors' medians: the unweighted potential can
    have several local minima, and on a short steady drive, whose gradient rests on the
    steering ratio's prior, the residuals' VIF at a subset's mode was well below that at all
    samples'.
    Returns ``(mode, converged, hessian, weights, vif)``.
    """
    dtype = obs.ay.dtype
    n = obs.speed.shape[0]
    stride = _search_stride(n)
    unit = jnp.ones(2, dtype=dtype)
    strides = (_search_stride(n, INFLATION_SEARCH_SAMPLES), stride) if stride > 1 else (1,)
    start = _start(obs, priors, surface)
    mode, _, _ = _levels(obs, start, strides, unit, priors, surface, max_steps)
    point = {k: v[0] for k, v in _constrain(mode[None], obs, unit, priors, surface).items()}
    steer, kin = (np.asarray(x) for x in _residuals_at(point, obs))
    vif = (
        residual_inflation(steer, np.asarray(obs.mask)),
        residual_inflation(kin, np.asarray(obs.mask_kinematic)),
    )
    weights = jnp.asarray([1.0 / vif[0], 1.0 / vif[1]], dtype=dtype)
    mode, ok, hess = _levels(obs, mode, (stride, 1), weights, priors, surface, max_steps)
    return mode, ok, hess, weights, vif


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
    obs = _padded(obs)
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
    names = [k for k in _SUMMARY_SITES if k in samples]
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
