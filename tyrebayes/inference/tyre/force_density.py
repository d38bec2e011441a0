"""A drive's measured-force density, deconvolved: what the model needs for E[ρ_true | ρ_obs].

With ρ_obs = ρ_true + ε, ε ~ Normal(0, η²), Tweedie's formula gives the true force of a window
from the density p of the *measured* forces, whatever the distribution of the true ones:
E[ρ_true | ρ_obs] = ρ_obs + η² s(ρ_obs) and Var[ρ_true | ρ_obs] = η² (1 + η² s′(ρ_obs)), with
s = d/dρ log p the score. A drive's forces are far from Gaussian (a dense cruising cluster, a long
tail of hard accelerations), so p has to be estimated without assuming a shape.

Why a deconvolved mixture and not a kernel estimate of p: the correction η² s is large where the
forces are dense and the noise is not small against their spread (near zero force with doubled
sensor noise a regression on the raw forces underestimates the slope by a third), and a kernel
estimate's score is noisy there — its bandwidth is set for the density, not for its derivative.
That noise is an error in the corrected force, which attenuates the fitted slope again: on two
simulated one-hour drives with the true slips and ideal white force noise at twice the default
sensors', a kernel score left C_x +3 to +14 % high, this mixture −1 to +2.3 %. Here p is a
mixture whose components are the true forces' mixture components widened by each window's own
noise, p_i(ρ) = Σ_k w_k Normal(ρ; m_k, τ_k² + η_i²), fitted by maximum likelihood (extreme
deconvolution, Bovy, Hogg & Roweis 2011, in one dimension): no component can be narrower than
the noise, so the score is smooth where the kernel estimate's was not, and heteroscedastic noise
is handled window by window.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ..._errors import BadInputError
from ...internal.device_arrays import device_array

N_COMPONENTS = 8
# EM is stopped after this many EM steps. The likelihood is flat along a ridge towards mixtures
# with ever narrower components (a deconvolution's maximum-likelihood mixing distribution is
# discrete), so EM may still be drifting when its gain per step is small: on 10 simulated
# one-hour drives (benchmarks/results/windows_step_speed.json) 10,000 plain EM steps moved
# E[ρ_true | ρ_obs] from where 400 plain steps had left it by up to 1.07 window noise sds (rms
# 0.06), and from where this limit of accelerated EM leaves it by up to 1.18 (rms 0.05). At this
# limit every drive's mixture was at least as likely as after 400 plain steps (3 of 10 drives
# reached it, 5 of 10 reached 400 plain steps), at 0.42 of the EM steps; the fast fit's C_xr of
# each drive moved by at most 0.06 of its posterior sd. Every step more costs a pass over the
# windows: a mixture stopped here is reported (ForceMixture.converged), not run on.
_MAX_ITERATIONS = 200
_TOLERANCE = 1e-6  # on the mean log-likelihood per window [nats]
#: Precision of the EM's per-window arithmetic. The mixture, its extrapolation and every sum over
#: windows stay in float64. On six simulated one-hour drives
#: (``benchmarks/results/windows_step_float32.json``) single precision per window took the windows
#: step from 0.74 to 0.61 CPU s per drive-hour and moved E[ρ_true | ρ_obs] by at most 0.056
#: window noise sds (rms 0.004) from the float64 EM's, where stopping at the step limit rather
#: than at the maximum-likelihood mixture leaves up to 1.19; each drive's fast-fit C_xr moved by
#: at most 0.003 of its posterior sd.
WINDOW_DTYPE = np.float32
# Growth and shrinkage of the bound on the extrapolation's step length (SQUAREM's default).
_STEP_FACTOR = 4.0


class ForceMixture(NamedTuple):
    """The true forces' Gaussian mixture from :func:`deconvolve_forces`.

    ``weights`` w_k [-], ``means`` m_k [-], ``variances`` τ_k² [-²]; ``iterations`` EM steps
    taken, ``converged`` whether the mean log-likelihood per window settled to within
    ``_TOLERANCE`` before the step limit.
    """

    weights: np.ndarray
    means: np.ndarray
    variances: np.ndarray
    iterations: int
    converged: bool


def deconvolve_forces(
    rho: Float[np.ndarray, "n"],
    noise_sd: Float[np.ndarray, "n"],
    n_components: int = N_COMPONENTS,
) -> ForceMixture:
    """Gaussian mixture of the true forces, given measured forces with known noise.

    Expectation-maximisation of Σ_i log Σ_k w_k Normal(ρ_i; m_k, τ_k² + η_i²), accelerated by
    squared extrapolation with a monotone safeguard (:func:`_em`): the same fixed points as plain
    EM, reached in fewer steps.

    Parameters
    ----------
    rho : ndarray
        Measured normalised forces [-] (finite).
    noise_sd : ndarray
        Each force's noise sd η_i [-] (> 0).
    n_components : int
        Mixture components.

    Returns
    -------
    ForceMixture
        w_k, m_k and τ_k² of the true forces' mixture, with the EM steps taken and whether it
        converged (a mixture stopped at the step limit is still usable: see ``_MAX_ITERATIONS``).
    """
    x = np.asarray(rho, dtype=float)
    noise2 = np.broadcast_to(np.asarray(noise_sd, dtype=float) ** 2, x.shape)[:, None]
    if x.size < 2 or not np.all(np.isfinite(x)) or not np.all(noise2 > 0):
        raise BadInputError(
            f"force density: expected at least 2 finite forces with noise sd > 0, got {x.size} "
            f"({int(np.sum(~np.isfinite(x)))} non-finite)"
        )
    k = min(n_components, x.size)
    means = np.quantile(x, (np.arange(k) + 0.5) / k)
    variances = np.full(k, max(np.var(x) / k**2, 1e-10))
    size = _padded_size(x.size)
    # Padding: a force of 0 with unit noise (finite everywhere), masked out of every sum.
    with jax.enable_x64(True):
        weights, means, variances, iterations, converged = _em(
            device_array(np.concatenate([x, np.zeros(size - x.size)]).astype(WINDOW_DTYPE)),
            device_array(
                np.concatenate([noise2[:, 0], np.ones(size - x.size)]).astype(WINDOW_DTYPE)
            ),
            device_array(np.arange(size) < x.size),
            device_array(means),
            device_array(variances),
            jnp.full(k, 1.0 / k),
            jnp.asarray(_MAX_ITERATIONS),
            jnp.asarray(_TOLERANCE),
        )
        return ForceMixture(
            np.asarray(weights),
            np.asarray(means),
            np.asarray(variances),
            int(iterations),
            bool(converged),
        )


def _padded_size(n: int) -> int:
    """Padded length of a drive's forces: 1,024, or the next of 4 sizes per octave above.

    One compiled EM serves every drive of similar length (a 10-60 min drive has 2,000-12,000
    slip windows: 11 shapes), wasting at most a fifth of the work on padding.
    """
    if n <= 1024:
        return 1024
    step = 1 << (int(np.floor(np.log2(n))) - 2)
    return int(-(-n // step) * step)


class _Components(eqx.Module):
    """The mixture inside the compiled EM: w_k [-], m_k [-], τ_k² [-²]."""

    weights: Float[Array, "k"]
    means: Float[Array, "k"]
    variances: Float[Array, "k"]


def _em_step(
    x: Float[Array, "n"],
    noise2: Float[Array, "n"],
    weight: Float[Array, "n"],
    mixture: _Components,
) -> tuple[_Components, Float[Array, ""]]:
    """One EM step of extreme deconvolution, and the mean log-likelihood of its input mixture.

    The E step takes the responsibilities of ``mixture``; the M step the weights, means and
    variances of the true forces' components (Bovy, Hogg & Roweis 2011). ``weight`` is 1 for a
    window, 0 for padding. The log-likelihood returned is that of ``mixture`` (not of the mixture
    returned): it comes out of the E step at no extra cost.
    """
    # The per-window arithmetic runs in the windows' precision (float32 from deconvolve_forces),
    # every sum over windows in the mixture's (float64): see WINDOW_DTYPE.
    acc = mixture.means.dtype
    n_real = jnp.sum(weight, dtype=acc)
    weights, means, variances = (
        a.astype(x.dtype) for a in (mixture.weights, mixture.means, mixture.variances)
    )
    log_weights = jnp.log(weights)
    # One length-n vector per component (k is small and static): the sums over components
    # are then elementwise and fuse, where (n, k) arrays reduced over their short minor axis
    # did not, and each step costs less.
    comps = range(means.shape[0])
    inverse = [1.0 / (variances[j] + noise2) for j in comps]
    offset = [x - means[j] for j in comps]
    # log(w_k Normal) = log w_k − ½ δ²/t − ½ log t, evaluated as w_k t^(−½) exp(−½ δ²/t) times
    # a per-window scale: one exp and one sqrt per window and component instead of an exp
    # and a log (a log costs more than both), the same numbers up to round-off. The scale is
    # the smallest −log w_k + ½ δ²/t, so the largest term is at least t^(−½) (no underflow).
    exponent = [0.5 * offset[j] ** 2 * inverse[j] - log_weights[j] for j in comps]
    scale = functools.reduce(jnp.minimum, exponent)
    scaled = [jnp.exp(scale - exponent[j]) * jnp.sqrt(inverse[j]) for j in comps]
    norm = functools.reduce(jnp.add, scaled)
    log_norm = jnp.log(norm) - scale
    per_window = weight / norm
    resp = [scaled[j] * per_window for j in comps]
    # Each component's posterior of the true force of each window (mean, variance).
    gain = [variances[j] * inverse[j] for j in comps]
    post_mean = [means[j] + gain[j] * offset[j] for j in comps]
    post_var = [variances[j] * (1.0 - gain[j]) for j in comps]
    count = jnp.stack([jnp.sum(resp[j], dtype=acc) for j in comps]) + 1e-300
    new_weights = jnp.maximum(count / n_real, 1e-300)
    new_means = jnp.stack([jnp.sum(resp[j] * post_mean[j], dtype=acc) for j in comps]) / count
    centre = new_means.astype(x.dtype)
    spread = jnp.stack(
        [
            jnp.sum(resp[j] * ((post_mean[j] - centre[j]) ** 2 + post_var[j]), dtype=acc)
            for j in comps
        ]
    )
    new_variances = jnp.maximum(spread / count, 1e-12)
    mean_log_lik = jnp.sum(jnp.where(weight > 0, log_norm, 0.0), dtype=acc) / n_real
    return _Components(new_weights, new_means, new_variances), mean_log_lik


def _unconstrained(mixture: _Components, force_sd: Float[Array, ""]) -> _Components:
    """Coordinates in which any extrapolated point is a valid mixture: log w, m / sd(ρ), log τ².

    All three are dimensionless and of order one, so that no one coordinate dominates the step
    length of :func:`_em`'s extrapolation.
    """
    return _Components(
        jnp.log(mixture.weights), mixture.means / force_sd, jnp.log(mixture.variances)
    )


def _constrained(point: _Components, force_sd: Float[Array, ""]) -> _Components:
    """Inverse of :func:`_unconstrained`, with the EM step's floors on w_k and τ_k²."""
    weights = jax.nn.softmax(jnp.nan_to_num(point.weights, nan=-jnp.inf, posinf=0.0))
    variances = jnp.exp(jnp.clip(point.variances, jnp.log(1e-12), 700.0))
    return _Components(jnp.maximum(weights, 1e-300), point.means * force_sd, variances)


@jax.jit
def _em(
    x: Float[Array, "n"],
    noise2: Float[Array, "n"],
    mask: Bool[Array, "n"],
    means: Float[Array, "k"],
    variances: Float[Array, "k"],
    weights: Float[Array, "k"],
    max_iterations: Int[Array, ""],
    tolerance: Float[Array, ""],
):
    """EM, accelerated by squared extrapolation, to the maximum-likelihood mixture.

    Plain EM converges linearly, and slowly where components overlap (a drive's dense cruising
    cluster): most of its steps each gain little, and the stopping rule on the gain could fire
    while the mixture was still drifting. SQUAREM (Varadhan & Roland 2008, scheme S3) takes two
    EM steps θ₁ = F(θ₀), θ₂ = F(θ₁), extrapolates along them, θ′ = θ₀ + 2a r + a² v with
    r = θ₁ − θ₀, v = θ₂ − 2θ₁ + θ₀, step length a = ‖r‖/‖v‖ (a = 1 gives θ₂), and takes one EM
    step from θ′ to stabilise it. It has the same fixed points as EM (at one, r = v = 0).
    Monotone safeguard: when θ′'s log-likelihood is below θ₁'s (or not finite), the cycle's
    result is θ₂, the plain EM steps; otherwise F(θ′), whose log-likelihood is at least θ′'s.
    Every cycle's mixture is therefore at least as likely as the last. The step length is
    bounded as in Varadhan & Roland's SQUAREM package: the bound starts at 1, grows by
    ``_STEP_FACTOR`` whenever a step at the bound is accepted and shrinks by it (to no less than
    1) when one is rejected: an unbounded long step overshoots along a flat ridge of the
    likelihood and is rejected, wasting its stabilising EM step.

    Extrapolation is in (log w, m / sd(ρ), log τ²), so every θ′ is a valid mixture.
    ``max_iterations`` bounds the EM steps (three per cycle, so up to two more may be taken);
    the loop stops when a cycle's gain in mean log-likelihood per window is below
    ``tolerance``, returning the mixture one EM step on from the settled one, as plain EM stops
    on its own gain per step. A cycle gains at least what plain EM's first step from the same
    mixture does, so wherever this rule stops, plain EM's would have stopped too.

    One compiled loop: in numpy each step made a dozen passes over windows × components, the
    per-drive stage's largest cost; fused, the steps are the same arithmetic in fewer passes.
    """
    weight = mask.astype(x.dtype)
    n_real = jnp.sum(weight)
    force_sd = jnp.sqrt(jnp.sum(weight * (x - jnp.sum(weight * x) / n_real) ** 2) / n_real)
    force_sd = jnp.where(force_sd > 0, force_sd, 1.0)

    def em(mixture):
        return _em_step(x, noise2, weight, mixture)

    def extrapolated(state):
        mixture, mixture1, iterations, step_max = state
        mixture2, log_lik1 = em(mixture1)
        start, one, two = (_unconstrained(m, force_sd) for m in (mixture, mixture1, mixture2))
        r = jax.tree.map(jnp.subtract, one, start)
        v = jax.tree.map(lambda a, b, c: c - 2.0 * b + a, start, one, two)
        r2 = sum(jnp.sum(leaf**2) for leaf in jax.tree.leaves(r))
        v2 = sum(jnp.sum(leaf**2) for leaf in jax.tree.leaves(v))
        length = jnp.sqrt(r2 / jnp.where(v2 > 0, v2, 1.0))
        length = jnp.clip(jnp.where(v2 > 0, jnp.nan_to_num(length, nan=1.0), 1.0), 1.0, step_max)
        point = jax.tree.map(lambda a, b, c: a + 2.0 * length * b + length**2 * c, start, r, v)
        mixture3, log_lik_point = em(_constrained(point, force_sd))
        accept = jnp.isfinite(log_lik_point) & (log_lik_point >= log_lik1)
        chosen = jax.tree.map(lambda a, b: jnp.where(accept, a, b), mixture3, mixture2)
        at_bound = length >= step_max
        step_max = jnp.where(
            accept,
            jnp.where(at_bound, _STEP_FACTOR * step_max, step_max),
            jnp.where(at_bound, jnp.maximum(1.0, step_max / _STEP_FACTOR), step_max),
        )
        return chosen, iterations + 3, step_max

    def cycle(state):
        mixture, previous, iterations, _, step_max = state
        mixture1, log_lik = em(mixture)
        converged = log_lik - previous < tolerance
        mixture, iterations, step_max = jax.lax.cond(
            converged,
            lambda s: (s[1], s[2] + 1, s[3]),
            extrapolated,
            (mixture, mixture1, iterations, step_max),
        )
        return mixture, log_lik, iterations, converged, step_max

    def running(state):
        return (state[2] < max_iterations) & ~state[3]

    init = (
        _Components(weights, means, variances),
        jnp.asarray(-jnp.inf),
        jnp.asarray(0),
        jnp.asarray(False),
        jnp.asarray(1.0),
    )
    mixture, _, iterations, converged, _ = jax.lax.while_loop(running, cycle, init)
    return mixture.weights, mixture.means, mixture.variances, iterations, converged


def _component_log_densities(x, noise2, weights, means, variances, xp=np):
    """log(w_k Normal(x_i; m_k, τ_k² + η_i²)) up to a constant, and τ_k² + η_i² (windows × k)."""
    total = variances + noise2
    return -0.5 * (x[:, None] - means) ** 2 / total - 0.5 * xp.log(total) + xp.log(weights), total


def force_density_score(
    rho: Float[np.ndarray, "n"],
    noise_sd: Float[np.ndarray, "n"],
    n_components: int = N_COMPONENTS,
) -> tuple[np.ndarray, np.ndarray]:
    """Score s_i = d/dρ log p_i(ρ_i) of each window's measured-force density, and ds_i/dρ.

    p_i is the deconvolved mixture of :func:`deconvolve_forces` widened by window i's own noise,
    so that ρ_i + η_i² s_i is E[ρ_true | ρ_obs] for that window (module docstring).

    Parameters
    ----------
    rho : ndarray
        Measured normalised forces of one drive's windows [-] (finite).
    noise_sd : ndarray
        Their noise sds η_i [-].
    n_components : int
        Mixture components.

    Returns
    -------
    (score, score_slope) : (ndarray, ndarray)
        s_i [1/-] and s′_i [1/-²].
    """
    weights, means, variances, *_ = deconvolve_forces(rho, noise_sd, n_components)
    x = np.asarray(rho, dtype=float)
    noise2 = np.broadcast_to(np.asarray(noise_sd, dtype=float) ** 2, x.shape)[:, None]
    log_phi, total = _component_log_densities(x, noise2, weights, means, variances)
    z = (x[:, None] - means) / total
    phi = np.exp(log_phi - log_phi.max(axis=1, keepdims=True))
    p = phi.sum(axis=1)
    score = (phi * -z).sum(axis=1) / p
    curvature = (phi * (z**2 - 1.0 / total)).sum(axis=1) / p
    return score, curvature - score**2


__all__ = ["N_COMPONENTS", "ForceMixture", "deconvolve_forces", "force_density_score"]
