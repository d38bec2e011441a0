"""The assumed-density Gaussian update: Newton to the mode of prior × block, Laplace at the mode.

Given the predicted Gaussian N(m, P) over θ and a block's log-likelihood ℓ(θ), the update keeps
the Gaussian N(θ*, H⁻¹) with θ* the mode of log N(θ; m, P) + ℓ(θ) and H the negative Hessian of
that sum at θ*: a Laplace approximation of the one-step posterior, projected back onto the
Gaussian family before the next step (assumed-density filtering; Särkkä 2013, *Bayesian
Filtering and Smoothing*, ch. 5-6, whose iterated posterior-linearisation filters do the same
with a statistical linearisation in place of the Hessian). When ℓ is quadratic in θ one Newton
step is exact and the update is the Kalman filter's (a test checks it).

The Newton iterations are at most :attr:`OnlineConfig.newton_steps`, fewer once a step is short
against the posterior sd (:attr:`OnlineConfig.newton_tolerance`), each with a Hessian floored to
positive definite and a step length chosen from a fixed set by the objective (0 included, so a
step never makes the objective worse). The loop is a ``lax.while_loop``: the update vmaps over
cars (running as many iterations as the slowest car needs) and scans over time.
"""

from __future__ import annotations

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

# Step lengths tried per Newton iteration (the best is taken; 0 keeps the point).
_STEP_LENGTHS = (1.0, 0.5, 0.2, 0.05, 0.01, 0.0)
# Relative eigenvalue floor of a covariance's inverse (a predicted covariance is positive
# definite; the floor only keeps round-off from making it otherwise).
_EIGEN_FLOOR = 1e-12


def _floored_inverse(matrix: Float[Array, "p p"]) -> Float[Array, "p p"]:
    symmetric = 0.5 * (matrix + matrix.T)
    finite = jnp.all(jnp.isfinite(symmetric))
    symmetric = jnp.where(finite, symmetric, jnp.eye(matrix.shape[0], dtype=matrix.dtype))
    eigenvalues, vectors = jnp.linalg.eigh(symmetric)
    floor = _EIGEN_FLOOR * jnp.max(jnp.abs(eigenvalues))
    inverse_values = 1.0 / jnp.maximum(eigenvalues, floor)
    return (vectors * inverse_values[None, :]) @ vectors.T


def _information(curvature: Float[Array, "p p"], absolute: bool = False) -> Float[Array, "p p"]:
    """The block's curvature −∇²ℓ with its negative eigenvalues set to 0 (or made positive).

    Far from the mode (the first blocks from a wide prior) −∇²ℓ is indefinite: the noise scales'
    and the curve's directions bend the wrong way there. A direction the block bends the other
    way is read as no information in it, never as negative precision, so the Newton matrix stays
    at least the prior's precision and the covariance never grows by an update.

    ``absolute`` keeps those eigenvalues' magnitudes instead (saddle-free Newton, Dauphin et al.
    2014): for the Newton *step*, where a cut direction would be held by the prior alone and the
    step along it could be orders of magnitude too long (a slip-drift τ sent to e^80 on the first
    block from the prior).
    """
    symmetric = 0.5 * (curvature + curvature.T)
    finite = jnp.all(jnp.isfinite(symmetric))
    symmetric = jnp.where(finite, symmetric, 0.0)
    eigenvalues, vectors = jnp.linalg.eigh(symmetric)
    kept = jnp.abs(eigenvalues) if absolute else jnp.maximum(eigenvalues, 0.0)
    return (vectors * kept[None, :]) @ vectors.T


class GaussianUpdate(eqx.Module):
    """The result of one Laplace update.

    Fields
    ------
    mean : Float[Array, "p"]
        Mode θ* of prior × block.
    cov : Float[Array, "p p"]
        Σ, the inverse of the negative Hessian there (module docstring).
    log_evidence : Float[Array, ""]
        The block's predictive log-density by the Laplace approximation,
        ℓ(θ*) − ½(θ* − m)ᵀP⁻¹(θ* − m) + ½ log(|Σ|/|P|) [nats] (exact for a Gaussian ℓ).
    """

    mean: Float[Array, "p"]
    cov: Float[Array, "p p"]
    log_evidence: Float[Array, ""]


def laplace_update(
    log_likelihood: Callable[[Float[Array, "p"]], Float[Array, ""]],
    mean: Float[Array, "p"],
    cov: Float[Array, "p p"],
    newton_steps: int,
    tolerance: float = 0.0,
) -> GaussianUpdate:
    """One assumed-density update of N(mean, cov) by a log-likelihood (module docstring).

    Parameters
    ----------
    log_likelihood : callable
        θ ↦ ℓ(θ), twice differentiable.
    mean, cov : array
        Predicted Gaussian.
    newton_steps : int
        Most Newton iterations (static).
    tolerance : float
        Stop once a step is shorter than this in units of the posterior sd (its Mahalanobis
        length under the Newton matrix): a settled posterior moves a fraction of an sd per
        block, and one step from the predicted mean is then the classic one-step Laplace
        update. 0 runs all ``newton_steps``.

    Returns
    -------
    GaussianUpdate
        The mode of the one-step posterior and the inverse of its negative Hessian (the
        block's part with negative eigenvalues cut, :func:`_information`, taken at the last
        Newton iterate before the last step), and the block's Laplace log-evidence.

    Examples
    --------
    >>> import jax.numpy as jnp
    >>> u = laplace_update(lambda t: -0.5 * jnp.sum(t**2), jnp.ones(2), jnp.eye(2), 1)
    >>> [round(float(v), 6) for v in u.mean], round(float(u.cov[0, 0]), 6)
    ([0.5, 0.5], 0.5)
    """
    precision = _floored_inverse(cov)

    def objective(theta):
        d = theta - mean
        value = 0.5 * d @ precision @ d - log_likelihood(theta)
        return jnp.where(jnp.isfinite(value), value, jnp.inf)

    gradient = jax.grad(lambda t: -log_likelihood(t))
    hessian = jax.jacfwd(gradient)
    lengths = jnp.asarray(_STEP_LENGTHS, dtype=mean.dtype)

    def newton(carry):
        i, theta, _, _ = carry
        curvature = hessian(theta)
        g = precision @ (theta - mean) + gradient(theta)
        newton_matrix = precision + _information(curvature, absolute=True)
        step = _floored_inverse(newton_matrix) @ g
        step = jnp.where(jnp.all(jnp.isfinite(step)), step, 0.0)
        candidates = theta[None, :] - lengths[:, None] * step[None, :]
        values = jax.vmap(objective)(candidates)
        best = jnp.argmin(values)
        moved = lengths[best] * step
        length = jnp.sqrt(jnp.abs(moved @ newton_matrix @ moved))
        return i + 1, candidates[best], _information(curvature), length

    def more(carry):
        i, _, _, length = carry
        return (i < newton_steps) & ((i == 0) | (length >= tolerance))

    # The Hessian is most of an iteration's cost (30 times the likelihood's for the Magic
    # Formula curve); by the last step it is small against the posterior sd, so the
    # covariance takes the information of the iterate before it.
    start = (jnp.zeros((), jnp.int32), mean, jnp.zeros_like(cov), jnp.asarray(jnp.inf, mean.dtype))
    _, mode, information, _ = jax.lax.while_loop(more, newton, start)
    post_cov = _floored_inverse(precision + information)
    _, log_det_ratio = jnp.linalg.slogdet(post_cov @ precision)
    log_evidence = -objective(mode) + 0.5 * log_det_ratio
    return GaussianUpdate(
        mean=mode,
        cov=post_cov,
        log_evidence=jnp.where(jnp.isfinite(log_evidence), log_evidence, 0.0),
    )


__all__ = ["GaussianUpdate", "laplace_update"]
