"""The in-car lateral estimator: c_y front and rear and the understeer gradient, block by block.

The parameters are the batch lateral model's (:mod:`tyrebayes.inference.lateral.model`), on
its unconstrained space (log for the positive sites): log c_y front and rear, log μ_y, the
steering ratio, the steering and a_y offsets, the roll gradient, the yaw inertia's factor, the
curve's shape, and the noise scales of the two equations and of the axle forces. Their
Gaussian starts at the batch model's priors and is updated every :data:`.LATERAL_STEP_S` of
driving by the assumed-density Laplace update of the longitudinal estimator
(:func:`~.laplace_update.laplace_update`: Newton steps to the mode of prior × the block's
likelihood, a Laplace covariance there), where the block's likelihood is the batch model's own
(:func:`~tyrebayes.inference.lateral.model.log_likelihoods` and its peak bound) on the block's
samples, braking samples left out (:mod:`.lateral_blocks`), with its Fisher information as the
curvature (:func:`~.lateral_likelihood.block_information`).

Correlated residuals: each equation is weighted by 1/VIF of its residuals, estimated as they
arrive by the batch fit's rule (:mod:`.lateral_vif`). The data's part of the state is kept as
per-equation Gaussian messages, re-weighted by the VIF as it stands at every step
(:class:`~.lateral_state.LateralState`): the posterior after 10 minutes weights every block by
the VIF of all 10 minutes, as the batch fit does.

A fixed-lag window: the last :data:`WINDOW_BLOCKS` blocks (5 minutes) keep their exact
likelihood, and each step takes Newton steps (from the last mode) to the mode of prior × the
older blocks' messages × the window's likelihood; a block's message is taken only when it leaves
the window, at the mode it helped find. A block linearised where the estimate stood after its
own 30 s (the first minutes, from a wide prior) would fix a wrong linearisation for good: on a
nonlinear front/rear level one early block can pull c_y far off and the narrowed Gaussian never
recovers. The cost is a window's likelihood per step instead of a block's.

Old blocks fade over :data:`MEMORY_S` (slow change of the tyres).

Readiness waits until the VIFs have seen :data:`~.lateral_vif.MIN_CHUNKS` batches of 30 s
(4 minutes of cornering data): before that the intervals leave out slow correlations they have
not yet measured. Then the batch fit's identification rule
(:data:`~tyrebayes.inference.lateral.posterior_checks.K_CONTRACTION`) in the Gaussian: the
understeer gradient is reported once its sd is at most half its prior's;
c_y front and rear once, in addition, each axle's log-sd is at most half its prior's: steady
cornering narrows K alone (δ = L/R + K a_y), and only yaw transients tell front from rear.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..lateral.data import CorneringObservations
from ..lateral.model import LateralPriors, residuals
from ..lateral.posterior_checks import K_CONTRACTION
from .laplace_update import laplace_update
from .lateral_blocks import LateralBlocks
from .lateral_likelihood import block_information, block_log_likelihood, block_parts
from .lateral_prior import LateralPrior, constrained, lateral_prior
from .lateral_run import LateralRun
from .lateral_state import LateralState, Window
from .lateral_summary import LateralTrajectory, OnlineLateral
from .lateral_vif import ResidualMoments

#: Time constant over which a block's information fades [s]: a tyre's cornering stiffness moves
#: with tread wear, temperature and pressure over hours, not minutes; an hour keeps a 10-minute
#: drive's blocks at 85 % or more of their weight.
MEMORY_S = 3600.0
#: Blocks whose likelihood is kept exact and whose messages are taken again at every step
#: (5 minutes): a block's message taken at a mode far from the final one (the first minutes,
#: from a wide prior) would fix a wrong linearisation for good; inside the window it is
#: re-linearised as the estimate settles (a fixed-lag Laplace smoother).
WINDOW_BLOCKS = 10
#: Newton iterations per block at most, and the step (in posterior sds) that ends them.
NEWTON_STEPS = 12
NEWTON_TOLERANCE = 0.05


def _symmetric_inverse(matrix: Float[Array, "p p"]) -> Float[Array, "p p"]:
    """Inverse of a precision (positive definite by construction: a prior's plus Fisher
    informations), by Cholesky."""
    factor = jnp.linalg.cholesky(0.5 * (matrix + matrix.T))
    return jax.scipy.linalg.cho_solve((factor, True), jnp.eye(matrix.shape[0], dtype=matrix.dtype))


class OnlineLateralEstimator(eqx.Module):
    """Recursive estimator of a car's lateral tyre parameters (module docstring).

    Attributes
    ----------
    prior : LateralPrior
    priors : LateralPriors
        The batch model's prior scales (its peak margin, its effects).
    memory_s : float
        Time constant over which old blocks' messages fade [s] (:data:`MEMORY_S`).
    newton_steps : int
    newton_tolerance : float
    """

    prior: LateralPrior
    priors: LateralPriors = eqx.field(static=True)
    memory_s: float = eqx.field(static=True, default=None)
    newton_steps: int = eqx.field(static=True, default=NEWTON_STEPS)
    newton_tolerance: float = eqx.field(static=True, default=NEWTON_TOLERANCE)

    @classmethod
    def create(
        cls,
        *,
        priors: LateralPriors | None = None,
        surface: str = "dry",
        steering_ratio: float = 15.0,
    ) -> OnlineLateralEstimator:
        """An estimator from the batch model's priors (``steering_ratio``: the vehicle file's).

        Examples
        --------
        >>> OnlineLateralEstimator.create().prior.names[-1]
        'force_noise'
        """
        priors = LateralPriors() if priors is None else priors
        prior = lateral_prior(priors, surface=surface, steering_ratio=steering_ratio)
        return cls(prior=prior, priors=priors, memory_s=MEMORY_S)

    def init(self, width: int = 300) -> LateralState:
        """The state before any block of ``width`` samples: the prior."""
        dtype = self.prior.mean.dtype
        zero = jnp.zeros((), dtype)
        p = self.prior.mean.shape[0]
        return LateralState(
            mean=self.prior.mean,
            cov=self.prior.cov,
            information=jnp.zeros((3, p, p), dtype),
            shift=jnp.zeros((3, p), dtype),
            time_s=zero,
            steering=ResidualMoments.empty(dtype),
            kinematic=ResidualMoments.empty(dtype),
            n_samples=zero,
            n_skipped=zero,
            window=Window.empty(WINDOW_BLOCKS, width, dtype),
        )

    def _posterior(self, information, shift, steering, kinematic):
        """The prior times the messages, the equations weighted 1/VIF: mean and covariance."""
        w = jnp.stack(
            [1.0 / steering.inflation(), 1.0 / kinematic.inflation(), jnp.ones(())]
        ).astype(shift.dtype)
        prior_precision = _symmetric_inverse(self.prior.cov)
        precision = prior_precision + jnp.einsum("k,kij->ij", w, information)
        cov = _symmetric_inverse(precision)
        mean = cov @ (prior_precision @ self.prior.mean + w @ shift)
        return mean, cov, w[:2]

    def update(
        self, state: LateralState, obs: CorneringObservations, time_s, skipped
    ) -> LateralState:
        """One block: the oldest window block's message frozen, the new block in, the mode of
        prior × frozen messages × the window's exact likelihood, the residuals' sums."""
        names = self.prior.names
        elapsed = jnp.maximum(time_s - state.time_s, 0.0)
        fade = jnp.exp(-elapsed / self.memory_s)
        # The block leaving the window: its message at the latest mode, which it helped find.
        _, gradient, leaving = block_parts(
            state.mean, state.window.block(0, obs), names, self.priors
        )
        information = fade * (state.information + leaving)
        shift = fade * (state.shift + jnp.einsum("kij,j->ki", leaving, state.mean) + gradient)
        window = state.window.pushed(obs)
        mean, cov, weights = self._posterior(information, shift, state.steering, state.kinematic)
        precision = _symmetric_inverse(cov)
        start = state.mean
        rows = jnp.arange(WINDOW_BLOCKS)

        def window_parts(theta):
            return jax.vmap(
                lambda i: block_information(
                    theta, window.block(i, obs), weights, names, self.priors
                )
            )(rows)

        # Newton from the latest mode, not the frozen messages' mean: the objective
        # ½(θ − m)ᵀP⁻¹(θ − m) − ℓ(θ) written about ``start`` (laplace_update's mean) by moving
        # the difference of the two quadratics into the likelihood.
        def moved(theta):
            d, e = theta - mean, theta - start
            return -0.5 * d @ precision @ d + 0.5 * e @ precision @ e

        def log_likelihood(theta):
            value = jax.vmap(
                lambda i: block_log_likelihood(
                    theta, window.block(i, obs), weights, names, self.priors
                )
            )(rows)
            return jnp.sum(value) + moved(theta)

        def curvature(theta):
            value, gradient, info = window_parts(theta)
            return (
                jnp.sum(value) + moved(theta),
                jnp.sum(gradient, axis=0) + precision @ (mean - start),
                jnp.sum(info, axis=0),
            )

        mode = laplace_update(
            log_likelihood,
            start,
            cov,
            self.newton_steps,
            self.newton_tolerance,
            curvature=curvature,
        ).mean
        steer, kinematic = residuals(obs, constrained(mode, names))
        steering = state.steering.add(steer, obs.mask)
        kinematic = state.kinematic.add(kinematic, obs.mask_kinematic)
        _, gradient, block = jax.vmap(
            lambda i: block_parts(mode, window.block(i, obs), names, self.priors)
        )(rows)
        window_information = jnp.sum(block, axis=0)
        window_shift = jnp.einsum("kij,j->ki", window_information, mode) + jnp.sum(gradient, 0)
        mean, cov, _ = self._posterior(
            information + window_information, shift + window_shift, steering, kinematic
        )
        return LateralState(
            mean=mean,
            cov=cov,
            information=information,
            shift=shift,
            window=window,
            time_s=jnp.maximum(time_s, state.time_s),
            steering=steering,
            kinematic=kinematic,
            n_samples=state.n_samples + jnp.sum(obs.mask),
            n_skipped=state.n_skipped + skipped,
        )

    def run(
        self, state: LateralState, blocks: LateralBlocks
    ) -> tuple[LateralState, LateralTrajectory]:
        """Scan :meth:`update` over the blocks; the last state and each block's moments."""
        index = {n: i for i, n in enumerate(self.prior.names)}
        rows = jnp.asarray([index["c_y_front"], index["c_y_rear"]])

        def step(carry, i):
            new = self.update(carry, blocks.block(i), blocks.time_s[i], blocks.n_skipped[i])
            moments = (new.time_s, new.mean[rows], new.cov[rows[:, None], rows[None, :]])
            return new, (*moments, new.vif_settled())

        last, (time_s, mean, cov, settled) = jax.lax.scan(step, state, jnp.arange(blocks.n_blocks))
        return last, LateralTrajectory(
            time_s=time_s, log_c_y_mean=mean, log_c_y_cov=cov, vif_settled=settled
        )

    def result(self, state: LateralState) -> OnlineLateral:
        """The estimate of a state (readiness included, module docstring)."""
        index = {n: i for i, n in enumerate(self.prior.names)}
        rows = [index["c_y_front"], index["c_y_rear"]]
        return OnlineLateral(
            mean=state.mean,
            cov=state.cov,
            names=self.prior.names,
            time_s=state.time_s,
            prior_log_c_y_mean=self.prior.mean[rows[0]],
            prior_log_c_y_sd=jnp.sqrt(self.prior.cov[rows[0], rows[0]]),
            contraction=K_CONTRACTION,
            n_samples=state.n_samples,
            n_skipped_longitudinal=state.n_skipped,
            steering_vif=state.steering.inflation(),
            kinematic_vif=state.kinematic.inflation(),
            vif_settled=state.vif_settled(),
        )


@eqx.filter_jit
def run_online_lateral(
    estimator: OnlineLateralEstimator, state: LateralState, blocks: LateralBlocks
) -> tuple[LateralState, LateralTrajectory]:
    """:meth:`OnlineLateralEstimator.run`, compiled (once per block shape and settings)."""
    return estimator.run(state, blocks)


def online_lateral(
    blocks: LateralBlocks,
    *,
    priors: LateralPriors | None = None,
    surface: str = "dry",
) -> LateralRun:
    """Run the lateral estimator from the batch priors over a drive's blocks (the command's path).

    Parameters
    ----------
    blocks : LateralBlocks
        From :func:`~.lateral_blocks.lateral_blocks`.
    priors : LateralPriors, optional
    surface : str
        Road surface: the centre of μ_y's prior.

    Returns
    -------
    LateralRun
        The estimate after the last block and each block's c_y moments; its ``to_dict()`` is
        the lateral part of ``tyrebayes online --json``.

    Examples
    --------
    A simulated cornering drive; the estimator's first compilation takes longer than a doctest
    should, so that line is not run here (``tyrebayes online`` runs it):

    >>> from tyrebayes import cornering_observations, lateral_blocks, load_vehicle
    >>> from tyrebayes.simulate.cornering import simulate_cornering
    >>> vehicle = load_vehicle("compact_fwd")
    >>> frame, _ = simulate_cornering(vehicle, duration_s=300.0, seed=3)
    >>> blocks = lateral_blocks(cornering_observations(frame, vehicle))
    >>> blocks.n_blocks
    10
    >>> run = online_lateral(blocks)  # doctest: +SKIP
    >>> run.to_dict()["lateral"]["ready"]  # doctest: +SKIP
    True
    """
    estimator = OnlineLateralEstimator.create(
        priors=priors, surface=surface, steering_ratio=float(blocks.steering_ratio)
    )
    last, trajectory = run_online_lateral(estimator, estimator.init(blocks.speed.shape[1]), blocks)
    return LateralRun(estimate=estimator.result(last), trajectory=trajectory)


__all__ = [
    "MEMORY_S",
    "NEWTON_STEPS",
    "NEWTON_TOLERANCE",
    "WINDOW_BLOCKS",
    "OnlineLateralEstimator",
    "online_lateral",
    "run_online_lateral",
]
