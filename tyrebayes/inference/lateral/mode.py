"""The lateral posterior's mode: whitened BFGS on the model's potential, away from saddles.

The potential is the NumPyro model's on its unconstrained space; BFGS runs in coordinates the
Hessian whitens, steps off any saddle near the tyre curve's peak, searches a long drive on
subsets of it (:mod:`.search`) and refines on all samples, and finds the mode again with each
equation weighted by 1/VIF of its residuals (:func:`~.inflation.residual_inflation`).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from numpyro.infer.util import potential_energy

from ...internal.stored_program import stored_program
from .data import CorneringObservations, G
from .inflation import residual_inflation
from .model import REAL_SITES, LateralPriors, lateral_model, residuals, sample_sites
from .search import INFLATION_SEARCH_SAMPLES, _search_blocks, _search_subset


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
        "curve_shape_excess_front": priors.curve_shape_excess_log_mean,
        "curve_shape_excess_rear": priors.curve_shape_excess_log_mean,
        "curve_curvature_gap_front": priors.curve_curvature_gap_log_mean,
        "curve_curvature_gap_rear": priors.curve_curvature_gap_log_mean,
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


def _potential(x, obs, weights, scale, mu_prior, priors):
    params = dict(zip(_site_names(obs.road_wheel, priors), x, strict=True))
    return potential_energy(lateral_model, (obs, priors, mu_prior, weights, scale), {}, params)


def _mu_prior(priors: LateralPriors, surface: str, dtype) -> jnp.ndarray:
    """μ_y's prior (median, log-sd) on ``surface`` as data of the compiled programs: a static
    surface name would compile every program once per surface a fleet's drives were on."""
    return jnp.asarray(priors.mu_y_prior(surface), dtype=dtype)


# BFGS works in whitened coordinates y, x = start + W y with W W' ≈ H⁻¹ (posterior sds), and
# stops when a step moves every one by less than BFGS_ATOL and the potential by less than
# about BFGS_RTOL·|f| (the tyre fit's tolerances, inference/tyre/laplace.py says why): 1e-4
# sds is far below the Laplace draws' Monte-Carlo error (1/√2000 = 0.022 sds).
BFGS_ATOL = 1e-4
BFGS_RTOL = 1e-8


@functools.partial(jax.jit, static_argnames=("priors", "max_steps"))
def _bfgs(x0, whiten, obs, weights, scale, mu_prior, priors, max_steps):
    """BFGS minimum of the potential from ``x0`` in the coordinates ``whiten`` gives.

    Returns ``(mode, converged, steps)``. Compiled once per observation shape and priors; the
    start, whitening, weights, data scale and μ_y's prior are data.
    """

    def f(y, _):
        return _potential(x0 + whiten @ y, obs, weights, scale, mu_prior, priors)

    solver = optx.BFGS(rtol=BFGS_RTOL, atol=BFGS_ATOL)
    sol = optx.minimise(f, solver, jnp.zeros_like(x0), max_steps=max_steps, throw=False)
    return x0 + whiten @ sol.value, sol.result == optx.RESULTS.successful, sol.stats["num_steps"]


_potential_at = jax.jit(_potential, static_argnames=("priors",))


@functools.partial(jax.jit, static_argnames=("priors",))
def _hessian(x, obs, weights, scale, mu_prior, priors):
    """The potential's Hessian at ``x``, one Hessian-vector product per coordinate in turn.

    ``jax.hessian`` pushes all the coordinates' tangents through the reverse pass at once, so
    its program holds every intermediate of the likelihood once per site (13 copies of a
    drive's length); the products in turn hold one, and give the same columns. On a long drive
    it was the largest part of the lateral fit's peak memory (``benchmarks/lateral_speed.py``).
    """

    def gradient(y):
        return jax.grad(_potential)(y, obs, weights, scale, mu_prior, priors)

    def column(tangent):
        return jax.jvp(gradient, (x,), (tangent,))[1]

    return jax.lax.map(column, jnp.eye(x.shape[0], dtype=x.dtype))


@functools.cache
def _stored(function, priors: LateralPriors, **static):
    """``function`` with its static arguments bound and its traced program kept on disk.

    A fleet worker drops its compiled programs when they would take it past its memory budget
    (:mod:`tyrebayes.batch.worker_memory`); the lateral fit's programs are then compiled-cache
    loads, without the seconds of tracing BFGS and the Hessian at three data shapes again
    (:func:`~tyrebayes.internal.stored_program.stored_program`). Results are NumPy arrays.
    """
    bound = functools.partial(function, priors=priors, **static)
    return stored_program(bound, (f"lateral{function.__name__}", priors, sorted(static.items())))


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


def _minimum(x0, obs, weights, scale, priors, mu_prior, max_steps, hess0=None, escapes: int = 3):
    """A local minimum of the potential (not a saddle): whitened BFGS, then away from any saddle.

    The whitening is the Hessian at ``x0`` (or ``hess0``, one at a nearby point). BFGS stops
    where the gradient vanishes; near the tyre curve's peak (a drive that used most of μ_y) the
    potential has saddles, where the Hessian has a negative eigenvalue. From one, the search
    steps both ways along that eigenvector, by the distance at which a quadratic of that
    curvature would drop the potential by 2, and goes on from the lower side.
    Returns ``(mode, converged, hessian)``.
    """
    args = (obs, weights, scale, mu_prior)
    hessian = _stored(_hessian, priors)
    bfgs = _stored(_bfgs, priors, max_steps=max_steps)
    hess = hessian(x0, *args) if hess0 is None else hess0
    if not np.all(np.isfinite(hess)):
        # a potential that is not finite at the start (data the masks let through): BFGS
        # would take all its steps on NaN
        return x0, False, hess
    mode, ok, _ = bfgs(x0, _whitening(hess), *args)
    hess = hessian(mode, *args)
    for _ in range(escapes):
        sym = 0.5 * (hess + hess.T)
        if not np.all(np.isfinite(sym)):
            break
        eig, vec = np.linalg.eigh(sym)
        if eig[0] > 0:
            break
        step = 2.0 / np.sqrt(abs(eig[0]))
        starts = [mode + sign * step * vec[:, 0] for sign in (1.0, -1.0)]
        potential = _stored(_potential_at, priors)
        values = [float(potential(x, *args)) for x in starts]
        mode, ok, _ = bfgs(starts[int(np.argmin(values))], _whitening(hess), *args)
        hess = hessian(mode, *args)
    return mode, bool(ok), hess


def _constrain(xs, obs, priors) -> dict:
    """Constrained draws of unconstrained draws ``xs`` (draws × sites), K included.

    The model's transforms are known (exp for the LogNormal sites, identity for the Normal
    ones), so the draws are mapped directly, without running the model's likelihood once per
    draw.
    """
    names = _site_names(obs.road_wheel, priors)
    xs = np.asarray(xs)
    out = {n: xs[:, i] if n in REAL_SITES else np.exp(xs[:, i]) for i, n in enumerate(names)}
    out["understeer_gradient"] = (1.0 / out["c_y_front"] - 1.0 / out["c_y_rear"]) / G
    return out


@jax.jit
def _residuals(point: dict, obs):
    return residuals(obs, point)


#: The steering and kinematic residuals at a point (a dict of the sites' values), as NumPy
#: arrays; its traced program kept on disk like the search's (:func:`_stored`).
_residuals_at = stored_program(_residuals, ("lateral-residuals",))


def _levels(obs, x, subsets, weights, priors, mu_prior, max_steps):
    """The mode found on ``subsets[0]`` stretches of the drive, refined on ``subsets[1]``...

    Each entry is a number of stretches (:func:`~.search._search_subset`) or ``None`` for all
    samples. Each level starts at the last one's mode, whitened by its Hessian (the subsets'
    data are scaled to the whole drive's weight, so every level's Hessian has about the whole's
    curvature). Returns ``(mode, converged, hessian)`` of the last level.
    """
    hess = None
    for count in dict.fromkeys(subsets):
        subset, scale = (obs, 1.0) if count is None else _search_subset(obs, count)
        scale = jnp.asarray(scale, dtype=obs.ay.dtype)
        x, ok, hess = _minimum(x, subset, weights, scale, priors, mu_prior, max_steps, hess)
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
    samples'. A mode whose μ_y lies far from its prior's median is searched for once more
    from that median (the comment below says why).
    Returns ``(mode, converged, hessian, weights, vif)``.
    """
    dtype = obs.ay.dtype
    n = obs.speed.shape[0]
    search = _search_blocks(n)
    unit = jnp.ones(2, dtype=dtype)
    first = (_search_blocks(n, INFLATION_SEARCH_SAMPLES), search) if search else (None,)
    start = _start(obs, priors, surface)
    mu_prior = _mu_prior(priors, surface, dtype)
    mode, _, _ = _levels(obs, start, first, unit, priors, mu_prior, max_steps)
    point = {k: v[0] for k, v in _constrain(mode[None], obs, priors).items()}
    steer, kin = (np.asarray(x) for x in _residuals_at(point, obs))
    vif = (
        residual_inflation(steer, np.asarray(obs.mask)),
        residual_inflation(kin, np.asarray(obs.mask_kinematic)),
    )
    weights = jnp.asarray([1.0 / vif[0], 1.0 / vif[1]], dtype=dtype)
    mode, ok, hess = _levels(obs, mode, (search, None), weights, priors, mu_prior, max_steps)
    # A curve that bends early is told by a low μ_y or by its shape: the potential can hold a
    # minimum in each. A mode whose μ_y lies more than one prior sd from the prior's median is
    # searched for again from that median, and the lower of the two minima kept. On a brush
    # curve with load transfer (a drive of benchmarks/lateral_simulated_drives.py, and
    # tests/inference/lateral/test_mode.py) a search from the priors' medians ended at a low
    # μ_y on a dry road, claimed it and read c_y high, where a lower minimum lay near the
    # prior's μ_y.
    i = _site_names(obs.road_wheel, priors).index("mu_y")
    if abs(float(mode[i] - start[i])) > priors.mu_y_prior(surface)[1]:
        again = np.asarray(mode).copy()
        again[i] = float(start[i])
        other = _levels(
            obs, jnp.asarray(again), (search, None), weights, priors, mu_prior, max_steps
        )
        potential = _stored(_potential_at, priors)
        scale = jnp.asarray(1.0, dtype=dtype)
        if float(potential(other[0], obs, weights, scale, mu_prior)) < float(
            potential(mode, obs, weights, scale, mu_prior)
        ):
            mode, ok, hess = other
    return mode, ok, hess, weights, vif
