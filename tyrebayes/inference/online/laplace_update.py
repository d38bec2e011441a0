"""The assumed-density Gaussian update: Newton to the mode of prior × block, Laplace at the mode.

Given the predicted Gaussian N(m, P) over θ and a block's log-likelihood ℓ(θ), the update keeps
the Gaussian N(θ*, H⁻¹) with θ* the mode of log N(θ; m, P) + ℓ(θ) and H the negative Hessian of
that sum at θ*: a Laplace approximation of the one-step posterior, projected back onto the
Gaussian family before the next step (assumed-density filtering; Särkkä 2013, *Bayesian
Filtering and Smoothing*, ch. 5-6, whose iterated posterior-linearisation filters do the same
with a statistical linearisation in place of the Hessian). When ℓ is quadratic in θ one Newton
step is exact and the update is the Kalman filter's (a test checks it).

The curvature is the exact negative Hessian of ℓ, or any information matrix a caller passes
in its place (``curvature``: the online estimator passes the block's Gauss-Newton information,
:func:`~.block_likelihood.block_curvature`, which costs about half as much and drops only the
curvature of the windows' quantities themselves). "Hessian" below means whichever is used.

The Newton iterations are at most :attr:`OnlineConfig.newton_steps`, fewer once a step is short
against the posterior sd (:attr:`OnlineConfig.newton_tolerance`), each with a Hessian floored to
positive definite. The full step is taken when it lowers the objective; otherwise the best of a
fixed set of shorter ones (0 included, so a step never makes the objective worse). Where the
quadratic model predicts the decrease badly, the next steps are Levenberg-Marquardt damped, the
Newton matrix's prior part scaled by 1 + λ (:func:`_next_damping`): far from the mode, the first
blocks from a wide prior, the Gauss-Newton information leaves out the large residuals' curvature
and its full steps overshoot by many prior sds, from which shortened steps of the same
direction climb back only slowly (a swap test's challenger, started from the type prior on a
simulated drive, stopped so far short of the mode after 10 iterations that its log Bayes factor
fell to −1,587 nats in the ``online_change`` benchmark run without damping, pair 26; damped,
the swap is found). A settled filter's steps are predicted well, and damping leaves
them as they were. The Hessian, most of an iteration's cost, is taken again only after a step
longer than :data:`_REFRESH_SD` posterior sds in the coordinates the block's curvature depends
on: a settled filter's first step from the predicted mean is mostly a fraction of an sd in those,
over which the curvature barely changes, so such an update costs one Hessian (a chord step
confirms the mode). The noise scales, which revert to their prior between steps
(:mod:`.process`), move by about a posterior sd at a step, so a good part of the steps take a
second (``benchmarks/results/online_speed.json``, ``where_the_time_goes``).
Coordinates the log-likelihood is quadratic in given the others (``quadratic``: a location
shift of Normal terms, such as the slip offset) do not count. Along them the Hessian changes
only in the scale directions, through the residuals: a step of k of the block's own sds
changes the curvature there by about k²/(2n) of itself, for a block of n windows, and
couples them to it with a correlation of about k√(2/n), whose sign follows the step's (a
drift's steps go either way, so it does not build up over blocks). Such a coordinate, widened
by its drift between steps, moves more than an sd at many steps of a settled filter; counted,
it would take the Hessian twice at each of them.

The Hessian at the predicted mean comes from the same pass as the objective and gradient
there, and the Newton matrix is inverted once per Hessian, not once per iteration.
The loop is a ``lax.while_loop``: the update vmaps over cars (running as many iterations as the
slowest car needs) and scans over time.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float, Int

# Step lengths tried when the full Newton step does not lower the objective (the best is taken;
# 0 keeps the point).
_STEP_LENGTHS = (0.5, 0.2, 0.05, 0.01, 0.0)
# A step longer than this many posterior sds takes the Hessian again at its end point.
_REFRESH_SD = 1.0
# Gain ratios (actual / predicted decrease) above which the quadratic model is trusted more,
# below which less, and the damping below which it is dropped (:func:`_next_damping`).
_GOOD_GAIN = 0.75
_POOR_GAIN = 0.25
_MIN_DAMPING = 1e-2
# Relative eigenvalue floor of a matrix inverted (a predicted covariance and a Newton matrix are
# positive definite; the floor only keeps round-off from making them otherwise).
_EIGEN_FLOOR = 1e-12


def _next_damping(
    damping: Float[Array, ""],
    *,
    actual: Float[Array, ""],
    predicted: Float[Array, ""],
    settled: Bool[Array, ""],
) -> Float[Array, ""]:
    """The Levenberg-Marquardt damping λ for the next step, from how well the quadratic model
    predicted this one's decrease (Nocedal & Wright 2006, *Numerical Optimization*, Alg. 4.1;
    Nielsen 1999's gain-ratio rule).

    The gain ratio ρ = actual / predicted decrease: above :data:`_GOOD_GAIN` the model is
    trusted more (λ/4, and 0 once below :data:`_MIN_DAMPING`), below :data:`_POOR_GAIN` less
    (4λ, at least 1). A step already within the tolerance carries no information on the model
    (its decreases are round-off) and ends the damping.
    """
    trusted = jnp.where(damping < _MIN_DAMPING * 4.0, 0.0, damping / 4.0)
    distrusted = jnp.maximum(1.0, 4.0 * damping)
    gain = actual / jnp.maximum(predicted, jnp.finfo(damping.dtype).tiny)
    new = jnp.where(gain > _GOOD_GAIN, trusted, jnp.where(gain < _POOR_GAIN, distrusted, damping))
    return jnp.where(settled, 0.0, new)


def _spd_inverse(matrix: Float[Array, "p p"]) -> tuple[Float[Array, "p p"], Float[Array, ""]]:
    """Inverse of a matrix positive definite by construction (a covariance, a precision plus a
    positive semi-definite information), and the matrix's own log-determinant.

    By Cholesky, a fraction of an eigendecomposition's cost at this size. Where round-off has
    made the matrix fail it (a non-finite factor), by its eigendecomposition instead, with the
    eigenvalues floored at :data:`_EIGEN_FLOOR` of the largest (and a non-finite matrix read as
    the identity): the inverse and log-determinant of the nearest matrix that is positive.
    """
    symmetric = 0.5 * (matrix + matrix.T)
    factor = jnp.linalg.cholesky(symmetric)

    def by_cholesky():
        identity = jnp.eye(matrix.shape[0], dtype=matrix.dtype)
        inverse = jax.scipy.linalg.cho_solve((factor, True), identity)
        return inverse, 2.0 * jnp.sum(jnp.log(jnp.diagonal(factor)))

    def by_eigenvalues():
        finite = jnp.all(jnp.isfinite(symmetric))
        clean = jnp.where(finite, symmetric, jnp.eye(matrix.shape[0], dtype=matrix.dtype))
        eigenvalues, vectors = jnp.linalg.eigh(clean)
        floored = jnp.maximum(eigenvalues, _EIGEN_FLOOR * jnp.max(jnp.abs(eigenvalues)))
        return (vectors / floored[None, :]) @ vectors.T, jnp.sum(jnp.log(floored))

    return jax.lax.cond(jnp.all(jnp.isfinite(factor)), by_cholesky, by_eigenvalues)


def _informations(
    curvature: Float[Array, "p p"],
) -> tuple[Float[Array, "p p"], Float[Array, "p p"]]:
    """The block's curvature −∇²ℓ with its negative eigenvalues set to 0, and made positive.

    Far from the mode (the first blocks from a wide prior) −∇²ℓ is indefinite: the noise scales'
    and the curve's directions bend the wrong way there. A direction the block bends the other
    way is read as no information in it, never as negative precision (the first matrix), so the
    covariance never grows by an update.

    The second keeps those eigenvalues' magnitudes instead (saddle-free Newton, Dauphin et al.
    2014): for the Newton *step*, where a cut direction would be held by the prior alone and the
    step along it could be orders of magnitude too long (a slip-drift τ sent to e^80 on the first
    block from the prior). One eigendecomposition gives both.
    """
    symmetric = 0.5 * (curvature + curvature.T)
    finite = jnp.all(jnp.isfinite(symmetric))
    symmetric = jnp.where(finite, symmetric, 0.0)
    eigenvalues, vectors = jnp.linalg.eigh(symmetric)

    def rebuilt(values):
        return (vectors * values[None, :]) @ vectors.T

    return rebuilt(jnp.maximum(eigenvalues, 0.0)), rebuilt(jnp.abs(eigenvalues))


class GaussianUpdate(eqx.Module):
    """The result of one Laplace update.

    Attributes
    ----------
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


Curvature = Callable[
    [Float[Array, "p"]], tuple[Float[Array, ""], Float[Array, "p"], Float[Array, "p p"]]
]


def exact_curvature(
    log_likelihood: Callable[[Float[Array, "p"]], Float[Array, ""]],
) -> Curvature:
    """θ ↦ (ℓ, ∇ℓ, −∇²ℓ) in one forward-over-reverse pass: the Hessian's columns are the
    directional derivatives of the gradient, whose primal is the gradient itself."""
    value_and_gradient = jax.value_and_grad(log_likelihood)

    def curvature(theta):
        basis = jnp.eye(theta.shape[0], dtype=theta.dtype)
        (value, gradient), (_, rows) = jax.vmap(
            lambda e: jax.jvp(value_and_gradient, (theta,), (e,)), out_axes=(None, 0)
        )(basis)
        return value, gradient, -rows.T

    return curvature


class _Iterate(NamedTuple):
    """The Newton iterations' state (the ``lax.while_loop``'s carry).

    Attributes
    ----------
    i : Int[Array, ""]
        Iterations done.
    theta : Float[Array, "p"]
        The current point.
    value, gradient : Array
        The objective and its gradient there.
    information, absolute : Float[Array, "p p"]
        The block's informations where the Hessian was last taken (:func:`_informations`).
    inverse : Float[Array, "p p"]
        The inverse of the (damped) Newton matrix from them.
    refresh : Bool[Array, ""]
        Whether the next iteration takes the Hessian again (the last step was long).
    damping : Float[Array, ""]
        The Levenberg-Marquardt λ of the next iteration.
    damped_with : Float[Array, ""]
        The λ of the last iteration, which ``inverse`` was taken with.
    length : Float[Array, ""]
        The last step's length in posterior sds.
    """

    i: Int[Array, ""]
    theta: Float[Array, "p"]
    value: Float[Array, ""]
    gradient: Float[Array, "p"]
    information: Float[Array, "p p"]
    absolute: Float[Array, "p p"]
    inverse: Float[Array, "p p"]
    refresh: Bool[Array, ""]
    damping: Float[Array, ""]
    damped_with: Float[Array, ""]
    length: Float[Array, ""]


@dataclasses.dataclass(frozen=True)
class _Newton:
    """The Newton iterations of one update: the objective ½(θ − m)ᵀP⁻¹(θ − m) − ℓ(θ) and the
    settings its steps read (:func:`laplace_update`'s parameters; ``precision`` is P⁻¹).

    Its methods are the loop's parts: :meth:`start`, :meth:`iterate` and :meth:`more`.
    """

    mean: Float[Array, "p"]
    precision: Float[Array, "p p"]
    log_likelihood: Callable[[Float[Array, "p"]], Float[Array, ""]]
    curvature: Curvature
    # Step lengths of the line search, and the coordinates whose steps can change the curvature
    # (a quadratic one's only moves the point).
    lengths: Float[Array, "k"]
    curved: Bool[Array, "p"]
    newton_steps: int
    tolerance: float | Float[Array, ""]
    damped: bool | Bool[Array, ""]

    def objective(self, theta: Float[Array, "p"]) -> Float[Array, ""]:
        """The objective at θ (+∞ where it is not finite)."""
        d = theta - self.mean
        value = 0.5 * d @ self.precision @ d - self.log_likelihood(theta)
        return jnp.where(jnp.isfinite(value), value, jnp.inf)

    def evaluated(self, theta: Float[Array, "p"]) -> tuple[Float[Array, ""], Float[Array, "p"]]:
        """The objective and its gradient at θ from one pass (the gradient is the next
        iteration's if θ is taken)."""

        def negative_log_likelihood(theta):
            return -self.log_likelihood(theta)

        d = theta - self.mean
        nll, g = jax.value_and_grad(negative_log_likelihood)(theta)
        value = 0.5 * d @ self.precision @ d + nll
        return jnp.where(jnp.isfinite(value), value, jnp.inf), self.precision @ d + g

    def start(self) -> _Iterate:
        """The first iterate: the predicted mean, its curvature taken in the same pass as the
        objective and gradient there, and the Newton matrix's inverse from it (undamped)."""
        log_lik, gradient, curvature = self.curvature(self.mean)
        value = jnp.where(jnp.isfinite(log_lik), -log_lik, jnp.inf)
        inf = jnp.asarray(jnp.inf, self.mean.dtype)
        i = jnp.zeros((), jnp.int32)
        objective_gradient = -gradient
        information, absolute = _informations(curvature)
        return _Iterate(
            i=i,
            theta=self.mean,
            value=value,
            gradient=objective_gradient,
            information=information,
            absolute=absolute,
            inverse=_spd_inverse(self.precision + absolute)[0],
            refresh=jnp.array(False),
            damping=jnp.zeros((), self.mean.dtype),
            damped_with=jnp.zeros((), self.mean.dtype),
            length=inf,
        )

    def factors(
        self, it: _Iterate
    ) -> tuple[Float[Array, "p p"], Float[Array, "p p"], Float[Array, "p p"]]:
        """The informations and the damped Newton matrix's inverse for this iteration: taken
        again only when the Hessian is (``refresh``) or the damping changed, else reused."""
        information, absolute = jax.lax.cond(
            it.refresh,
            lambda: _informations(self.curvature(it.theta)[2]),
            lambda: (it.information, it.absolute),
        )
        inverse = jax.lax.cond(
            it.refresh | (it.damping != it.damped_with),
            lambda: _spd_inverse((1.0 + it.damping) * self.precision + absolute)[0],
            lambda: it.inverse,
        )
        return information, absolute, inverse

    def line_search(
        self, it: _Iterate, step: Float[Array, "p"]
    ) -> tuple[Float[Array, ""], Float[Array, ""], Float[Array, ""], Float[Array, "p"]]:
        """The full step's objective, and the step length taken with the objective and gradient
        at its end: the full step if it does not raise the objective, else the best of
        :data:`_STEP_LENGTHS`."""
        theta = it.theta
        full_value, full_gradient = self.evaluated(theta - step)

        def shorter():
            candidates = theta[None, :] - self.lengths[:, None] * step[None, :]
            taken = self.lengths[jnp.argmin(jax.vmap(self.objective)(candidates))]
            return (taken, *self.evaluated(theta - taken * step))

        accepted = full_value <= it.value
        taken, new_value, new_gradient = jax.lax.cond(
            accepted,
            lambda: (jnp.ones((), self.mean.dtype), full_value, full_gradient),
            shorter,
        )
        return full_value, taken, new_value, new_gradient

    def iterate(self, it: _Iterate) -> _Iterate:
        """One Newton iteration: the step, its line search, the next damping, and whether the
        step was long enough to take the Hessian again."""
        information, absolute, inverse = self.factors(it)
        step = inverse @ it.gradient
        step = jnp.where(jnp.all(jnp.isfinite(step)), step, 0.0)
        full_value, taken, new_value, new_gradient = self.line_search(it, step)
        moved = taken * step
        newton_matrix = self.precision + absolute
        step_curvature = step @ newton_matrix @ step
        new_damping = _next_damping(
            it.damping,
            actual=it.value - full_value,
            predicted=step @ it.gradient - 0.5 * step_curvature,
            settled=jnp.sqrt(jnp.abs(step_curvature)) < self.tolerance,
        )
        new_damping = jnp.where(self.damped, new_damping, 0.0)
        length = jnp.sqrt(jnp.abs(moved @ newton_matrix @ moved))
        # The step's length in the curved coordinates' conditional sds (the Newton matrix's
        # block): never shorter than in their marginal sds.
        bending = jnp.where(self.curved, moved, 0.0)
        refresh = jnp.sqrt(jnp.abs(bending @ newton_matrix @ bending)) > _REFRESH_SD
        return _Iterate(
            i=it.i + 1,
            theta=it.theta - moved,
            value=new_value,
            gradient=new_gradient,
            information=information,
            absolute=absolute,
            inverse=inverse,
            refresh=refresh,
            damping=new_damping,
            damped_with=it.damping,
            length=length,
        )

    def more(self, it: _Iterate) -> Bool[Array, ""]:
        """Whether to iterate again: fewer than ``newton_steps`` done, and the last step not
        yet within the tolerance. A step damped short is not a converged one: the loop goes on
        until an undamped step is within the tolerance."""
        return (it.i < self.newton_steps) & (
            (it.i == 0) | (it.length >= self.tolerance) | (it.damped_with > 0)
        )


def _gaussian_update(
    newton: _Newton, last: _Iterate, log_det_cov: Float[Array, ""]
) -> GaussianUpdate:
    """The update from the last iterate: its mode, the inverse of prior precision plus the
    information where the Hessian was last taken, and the Laplace log-evidence."""
    post_cov, log_det_newton = _spd_inverse(newton.precision + last.information)
    # log(|Σ|/|P|) with Σ = (P⁻¹ + information)⁻¹.
    log_det_ratio = -(log_det_newton + log_det_cov)
    log_evidence = -last.value + 0.5 * log_det_ratio
    return GaussianUpdate(
        mean=last.theta,
        cov=post_cov,
        log_evidence=jnp.where(jnp.isfinite(log_evidence), log_evidence, 0.0),
    )


def laplace_update(
    log_likelihood: Callable[[Float[Array, "p"]], Float[Array, ""]],
    mean: Float[Array, "p"],
    cov: Float[Array, "p p"],
    newton_steps: int,
    tolerance: float | Float[Array, ""] = 0.0,
    quadratic: Bool[Array, "p"] | None = None,
    curvature: Curvature | None = None,
    damped: bool | Bool[Array, ""] = True,
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
    quadratic : bool array, optional
        Coordinates ℓ is quadratic in given the others: a step along them alone does not take
        the Hessian again (module docstring). None: every coordinate counts.
    curvature : callable, optional
        θ ↦ (ℓ(θ), ∇ℓ(θ), an information matrix standing for −∇²ℓ(θ)), e.g. a Gauss-Newton
        one (:func:`~.block_likelihood.block_curvature`). None: the exact Hessian
        (:func:`exact_curvature`).
    damped : bool
        Whether steps the quadratic model predicts badly damp the next ones
        (:func:`_next_damping`); False takes every step undamped, shortened by the line search
        only.

    Returns
    -------
    GaussianUpdate
        The mode of the one-step posterior and the inverse of its negative Hessian (the
        block's part with negative eigenvalues cut, :func:`_informations`, taken where the
        Hessian was last taken: the end of the last step longer than ``_REFRESH_SD`` sds in
        the coordinates not ``quadratic``, or the predicted mean), and the block's Laplace
        log-evidence.

    Examples
    --------
    >>> import jax.numpy as jnp
    >>> u = laplace_update(lambda t: -0.5 * jnp.sum(t**2), jnp.ones(2), jnp.eye(2), 1)
    >>> [round(float(v), 6) for v in u.mean], round(float(u.cov[0, 0]), 6)
    ([0.5, 0.5], 0.5)
    """
    precision, log_det_cov = _spd_inverse(cov)
    newton = _Newton(
        mean=mean,
        precision=precision,
        log_likelihood=log_likelihood,
        curvature=exact_curvature(log_likelihood) if curvature is None else curvature,
        lengths=jnp.asarray(_STEP_LENGTHS, dtype=mean.dtype),
        curved=jnp.ones(mean.shape, bool) if quadratic is None else ~jnp.asarray(quadratic),
        newton_steps=newton_steps,
        tolerance=tolerance,
        damped=damped,
    )
    last = jax.lax.while_loop(newton.more, newton.iterate, newton.start())
    return _gaussian_update(newton, last, log_det_cov)


__all__ = ["Curvature", "GaussianUpdate", "exact_curvature", "laplace_update"]
