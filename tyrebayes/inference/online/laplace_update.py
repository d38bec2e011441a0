"""The assumed-density Gaussian update: Newton to the mode of prior × block, Laplace at the mode.

Given the predicted Gaussian N(m, P) over θ and a block's log-likelihood ℓ(θ), the update keeps
the Gaussian N(θ*, H⁻¹) with θ* the mode of log N(θ; m, P) + ℓ(θ) and H the negative Hessian of
that sum at θ*: a Laplace approximation of the one-step posterior, projected back onto the
Gaussian family before the next step (assumed-density filtering; Särkkä 2013, *Bayesian
Filtering and Smoothing*, ch. 5-6, whose iterated posterior-linearisation filters do the same
with a statistical linearisation in place of the Hessian). When ℓ is quadratic in θ one Newton
step is exact and the update is the Kalman filter's (a test checks it).

The Newton iterations are a fixed number (:attr:`OnlineConfig.newton_steps`), each with a
Hessian floored to positive definite and a step length chosen from a fixed set by the objective
(0 included, so a step never makes the objective worse): no Python control flow, so the update
vmaps over cars and scans over time.
"""

from __future__ import annotations

from collections.abc import Callable

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


def laplace_update(
    log_likelihood: Callable[[Float[Array, "p"]], Float[Array, ""]],
    mean: Float[Array, "p"],
    cov: Float[Array, "p p"],
    newton_steps: int,
) -> tuple[Float[Array, "p"], Float[Array, "p p"]]:
    """One assumed-density update of N(mean, cov) by a log-likelihood (module docstring).

    Parameters
    ----------
    log_likelihood : callable
        θ ↦ ℓ(θ), twice differentiable.
    mean, cov : array
        Predicted Gaussian.
    newton_steps : int
        Newton iterations (static).

    Returns
    -------
    (mean, cov)
        The mode of the one-step posterior and the inverse of its negative Hessian (the
        block's part with negative eigenvalues cut, :func:`_information`, taken at the last
        Newton iterate before the last step: one Newton step is then the classic one-step
        Laplace update).

    Examples
    --------
    >>> import jax.numpy as jnp
    >>> m, c = laplace_update(lambda t: -0.5 * jnp.sum(t**2), jnp.ones(2), jnp.eye(2), 1)
    >>> [round(float(v), 6) for v in m], round(float(c[0, 0]), 6)
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

    def newton(carry, _):
        theta, _ = carry
        curvature = hessian(theta)
        information = _information(curvature)
        g = precision @ (theta - mean) + gradient(theta)
        step = _floored_inverse(precision + _information(curvature, absolute=True)) @ g
        step = jnp.where(jnp.all(jnp.isfinite(step)), step, 0.0)
        candidates = theta[None, :] - lengths[:, None] * step[None, :]
        values = jax.vmap(objective)(candidates)
        return (candidates[jnp.argmin(values)], information), None

    # The covariance takes the block's information at the last iterate before the last step:
    # the Hessian is most of a step's cost (30 times the likelihood's for the Magic Formula
    # curve), and by then the step is small against the posterior sd.
    start = (mean, jnp.zeros_like(cov))
    (mode, information), _ = jax.lax.scan(newton, start, None, length=newton_steps)
    return mode, _floored_inverse(precision + information)


__all__ = ["laplace_update"]
