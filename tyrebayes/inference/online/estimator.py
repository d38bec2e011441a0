"""The in-car estimator: the per-tyre posterior updated online, one block of windows at a time.

:class:`OnlineEstimator` is pure JAX: ``init(prior)`` gives a :class:`~.state.FilterState`,
``update(state, block)`` one step, ``run(state, blocks)`` a ``lax.scan`` over a drive's blocks,
``summary(state)`` the estimate; all jit, and vmap over cars (a state and blocks with a leading
car axis).

One step (Särkkä 2013, ch. 5-6; module docstrings of the parts):

1. predict: θ's covariance grows by the random-walk drift over the time since the last step
   (:data:`~.config.DRIFT_PER_SQRT_S`), and the noise scales revert towards their prior
   (:data:`~.config.REVERSION_S`, :mod:`.process`); at a drive start the per-drive coordinates
   (:data:`~.parameters.PER_DRIVE`) take their prior again, uncorrelated with the rest;
2. update: the Laplace update on the batch model's own per-window likelihood of the block
   (:mod:`.laplace_update`, :mod:`.block_likelihood`), slips weighted by 1/VIF, with the
   block's Gauss-Newton information as its curvature (:attr:`OnlineConfig.gauss_newton`);
3. swap: for the first steps of a drive, a challenger filter whose tyre coordinates started
   again from the prior at the drive start is updated by the same block, its Newton steps
   damped (:mod:`.laplace_update`); the log Bayes factor of the two (:mod:`.swap`) past its
   threshold makes the challenger the estimate;
4. change: the two-sided CUSUM of a mid-drive C_xr step on the block's predictive likelihood
   ratio, from the predicted and the updated Gaussians (:mod:`.change`); an alarm restarts the
   tyre's and the drive's coordinates (:data:`~.parameters.TYRE_COORDINATES`,
   :data:`~.parameters.PER_DRIVE`) from the type prior, since in the steps before the alarm the
   drive's slip offset took up part of the change; the sensor's noise levels are kept. The
   block that raised the alarm is left out: its information was taken at the old tyre's mode,
   and carried from there to the prior as a linear message it can land far outside the prior
   (a block of turning windows whose slips sat far off the curve sent C_x to zero);
5. the standardised residuals at the new mode feed the VIF estimate (:mod:`.inflation`).

Examples
--------
>>> est = OnlineEstimator.create(model="brush")  # doctest: +SKIP
>>> state = est.init(type_prior(model="brush"))  # doctest: +SKIP
>>> run = est.run(state, window_blocks(windows))  # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float, Int

from ...internal.renamed import renamed_keyword
from ..tyre.model import TyrePriors, check_model
from .block_likelihood import (
    block_curvature,
    block_log_likelihood,
    standardised_slip_residuals,
)
from .change import cusum_step, predictive_shift_ratios
from .config import OnlineConfig, default_config
from .estimate import state_moments, summary_of
from .inflation import accrue_residuals, empty_inflation, inflation_in_use
from .laplace_update import GaussianUpdate, laplace_update
from .parameters import (
    PER_DRIVE,
    QUADRATIC,
    TYRE_COORDINATES,
    GaussianPrior,
    reset_to_prior,
    type_prior,
)
from .process import predict
from .run import OnlineRun
from .state import FilterState
from .summary import (
    OnlineSummary,
    StateMoments,
)
from .swap import either, swap_step
from .windows import STEP_S, WindowBlocks


class _SwapTest(NamedTuple):
    """What the swap test of a step gives (:meth:`OnlineEstimator._swap_test`).

    Attributes
    ----------
    challenged : GaussianUpdate
        The challenger updated by the block (the estimate's update when the test is off).
    drive_steps : Int[Array, ""]
        Steps since the drive start (the window's length when no tyre is carried over).
    active : Bool[Array, ""]
        Whether the test runs at this step.
    log_bayes_factor : Float[Array, ""]
        Its running log Bayes factor of a swap [nats].
    swapped : Bool[Array, ""]
        Whether it passed its threshold: the challenger becomes the estimate.
    """

    challenged: GaussianUpdate
    drive_steps: Int[Array, ""]
    active: Bool[Array, ""]
    log_bayes_factor: Float[Array, ""]
    swapped: Bool[Array, ""]


class OnlineEstimator(eqx.Module):
    """Recursive estimator of one tyre set's parameters (module docstring).

    Attributes
    ----------
    prior : GaussianPrior
        The type prior it starts from and restarts at after a change alarm.
    config : OnlineConfig
        Drift, Newton steps, change detection, readiness.
    priors : TyrePriors
        The batch model's prior scales (the shape family's constants).

    Examples
    --------
    An estimator for the Magic Formula on dry roads, and its state before any window:

    >>> estimator = OnlineEstimator.create(model="magic", surface="dry")
    >>> estimator.model, estimator.prior.names[:3]
    ('magic', ('log_c_xr', 'temp_sensitivity', 'log_mu_max'))
    >>> state = estimator.init()
    >>> state.mean.shape, float(state.time_s), float(state.n_slip_windows)
    ((11,), 0.0, 0.0)

    :meth:`run` takes it through the steps of a stream (:func:`~.driver.online_estimate`).
    """

    prior: GaussianPrior
    config: OnlineConfig
    priors: TyrePriors

    @classmethod
    @renamed_keyword("kind", "model", what="the tyre-curve model")
    def create(
        cls,
        *,
        model: str = "magic",
        surface: str = "dry",
        priors: TyrePriors | None = None,
        config: OnlineConfig | None = None,
        imu_gain_log_sd: float = 0.0,
    ) -> OnlineEstimator:
        """An estimator with the type prior of ``priors`` and the stated default settings."""
        check_model(model)
        priors = TyrePriors() if priors is None else priors
        prior = type_prior(priors, model=model, surface=surface, imu_gain_log_sd=imu_gain_log_sd)
        config = config or default_config(model, priors.load_sensitive)
        return cls(prior=prior, config=config, priors=priors)

    @property
    def model(self) -> str:
        return self.prior.model

    @property
    def _index(self) -> dict:
        return {n: i for i, n in enumerate(self.prior.names)}

    def init(self, prior: GaussianPrior | None = None, time_s=0.0) -> FilterState:
        """The state before any window: the type prior (default this estimator's)."""
        prior = self.prior if prior is None else prior
        if prior.model != self.model:
            raise ValueError(f"prior: expected model {self.model!r}, got {prior.model!r}")
        dtype = prior.mean.dtype
        zero = jnp.zeros((), dtype=dtype)
        return FilterState(
            mean=prior.mean,
            cov=prior.cov,
            time_s=jnp.asarray(time_s, dtype=dtype),
            start_s=jnp.asarray(time_s, dtype=dtype),
            n_slip_windows=zero,
            n_excited_windows=zero,
            n_limit_windows=zero,
            temperature_sum=zero,
            cusum_up=zero,
            cusum_down=zero,
            challenger_mean=prior.mean,
            challenger_cov=prior.cov,
            log_bayes_factor=zero,
            drive_steps=jnp.asarray(self.config.swap_window_steps, dtype=jnp.int32),
            n_alarms=jnp.zeros((), dtype=jnp.int32),
            alarm=jnp.zeros((), dtype=bool),
            swap_alarm=jnp.zeros((), dtype=bool),
            inflation=empty_inflation(dtype),
        )

    def update(self, state: FilterState, block: WindowBlocks) -> FilterState:
        """One step: predict, test for change, update by one block of windows (unbatched).

        The steps of the module docstring, each a method: the block's Laplace update
        (:meth:`_block_update`), the prediction (:meth:`_moved`), the swap test
        (:meth:`_swap_test`), the change detector (:meth:`_change_test`) and the counters
        (:meth:`_next_state`).
        """
        laplace = self._block_update(state, block)
        elapsed = jnp.maximum(block.time_s - state.time_s, 0.0)
        start = block.drive_start
        moved = self._moved(state.mean, state.cov, elapsed)
        predicted = reset_to_prior(self.prior, *moved, PER_DRIVE, start)
        # The estimate's steps are undamped: damping them moves where the update of a block the
        # model does not explain lands, and the noise scales absorb such a block either way
        # until they revert (README, "Why 5 of 30 swaps are missed" and after). Undamped, its
        # first blocks from the prior can stop short of their modes; that costs the estimate
        # those blocks' information, not a test's running sum.
        updated = laplace(*predicted, damped=False)
        swap = self._swap_test(state, block, predicted, updated, elapsed, laplace)
        up, down, shifted = self._change_test(state, block, predicted, updated, swap.swapped)
        alarm = swap.swapped | shifted
        restarted = reset_to_prior(self.prior, *predicted, TYRE_COORDINATES + PER_DRIVE, shifted)
        challenged = swap.challenged
        mean, cov = either(
            swap.swapped,
            (challenged.mean, challenged.cov),
            either(shifted, restarted, (updated.mean, updated.cov)),
        )
        challenger = either(swap.active & ~alarm, (challenged.mean, challenged.cov), (mean, cov))
        return self._next_state(
            state,
            block,
            mean=mean,
            cov=cov,
            challenger=challenger,
            swap=swap,
            cusum=(up, down),
            alarm=alarm,
            shifted=shifted,
        )

    def _block_update(
        self, state: FilterState, block: WindowBlocks
    ) -> Callable[..., GaussianUpdate]:
        """Step 2's update, (mean, cov, damped) ↦ the Laplace update by the block's likelihood,
        its slips weighted by 1/VIF, with its Gauss-Newton information as the curvature
        (:attr:`OnlineConfig.gauss_newton`)."""
        cfg = self.config
        weight = 1.0 / inflation_in_use(
            state.inflation, cfg.initial_inflation, cfg.inflation_prior_blocks
        )

        def log_likelihood(theta):
            return block_log_likelihood(theta, block, weight, self.model, self.priors)

        def gauss_newton(theta):
            return block_curvature(theta, block, weight, self.model, self.priors)

        quadratic = jnp.asarray([n in QUADRATIC for n in self.prior.names])

        def laplace(mean, cov, damped):
            return laplace_update(
                log_likelihood,
                mean,
                cov,
                cfg.newton_steps,
                cfg.newton_tolerance,
                quadratic,
                curvature=gauss_newton if cfg.gauss_newton else None,
                damped=damped,
            )

        return laplace

    def _moved(
        self, mean: Float[Array, " p"], cov: Float[Array, "p p"], elapsed: Float[Array, ""]
    ) -> tuple[Float[Array, " p"], Float[Array, "p p"]]:
        """Step 1's prediction over ``elapsed`` seconds: the random-walk drift and the noise
        scales' reversion (:mod:`.process`)."""
        cfg = self.config
        return predict(self.prior, mean, cov, elapsed, cfg.drift_sd_per_sqrt_s, cfg.reversion_s)

    def _swap_test(
        self,
        state: FilterState,
        block: WindowBlocks,
        predicted: tuple[Float[Array, " p"], Float[Array, "p p"]],
        updated: GaussianUpdate,
        elapsed: Float[Array, ""],
        laplace: Callable[..., GaussianUpdate],
    ) -> _SwapTest:
        """Step 3: the challenger's update by the block over the first steps of a drive, and
        the swap test's log Bayes factor of it against the estimate (:mod:`.swap`)."""
        cfg = self.config
        start = block.drive_start
        # The swap test's challenger: from a drive start, the tyre's coordinates anew.
        challenger = either(
            start,
            reset_to_prior(self.prior, *predicted, TYRE_COORDINATES, start),
            self._moved(state.challenger_mean, state.challenger_cov, elapsed),
        )
        # A drive start with no slip window since the (re)start carries nothing of a tyre to
        # test against: its challenger would be the estimate itself, so the test stays off.
        carried = state.n_slip_windows > 0
        drive_steps = jnp.where(
            start, jnp.where(carried, 0, cfg.swap_window_steps), state.drive_steps + 1
        )
        active = drive_steps < cfg.swap_window_steps
        # The challenger's are damped (Levenberg-Marquardt, .laplace_update): it starts from the
        # type prior at every drive start, where Gauss-Newton's full steps can overshoot by many
        # prior sds, and its Bayes factor sums the evidences of every block from the first,
        # which are right only at the mode.
        challenged = jax.lax.cond(
            active,
            lambda: laplace(*challenger, damped=True),
            lambda: updated,
        )
        log_bayes_factor, swapped = swap_step(
            challenged,
            updated,
            state.log_bayes_factor,
            drive_start=start,
            active=active,
            threshold=cfg.swap_threshold,
        )
        return _SwapTest(challenged, drive_steps, active, log_bayes_factor, swapped)

    def _change_test(
        self,
        state: FilterState,
        block: WindowBlocks,
        predicted: tuple[Float[Array, " p"], Float[Array, "p p"]],
        updated: GaussianUpdate,
        swapped: Bool[Array, ""],
    ) -> tuple[Float[Array, ""], Float[Array, ""], Bool[Array, ""]]:
        """Step 4: the two-sided CUSUM of a C_xr step on the block's predictive likelihood
        ratio (:mod:`.change`): its two sums and whether it raised an alarm."""
        cfg = self.config
        c_index = self._index["log_c_xr"]
        return cusum_step(
            predictive_shift_ratios(predicted, updated, index=c_index, shift=cfg.change_log_shift),
            state.cusum_up,
            state.cusum_down,
            armed=~swapped & (jnp.sqrt(predicted[1][c_index, c_index]) <= cfg.change_gate_log_sd),
            threshold=cfg.change_threshold,
            # Per STEP_S of the step's span: a packed step carries more windows (.windows).
            max_increment=cfg.change_threshold
            / (cfg.change_min_steps - 0.5)
            * jnp.maximum(block.span_s / STEP_S, 1.0),
        )

    def _next_state(
        self,
        state: FilterState,
        block: WindowBlocks,
        *,
        mean: Float[Array, " p"],
        cov: Float[Array, "p p"],
        challenger: tuple[Float[Array, " p"], Float[Array, "p p"]],
        swap: _SwapTest,
        cusum: tuple[Float[Array, ""], Float[Array, ""]],
        alarm: Bool[Array, ""],
        shifted: Bool[Array, ""],
    ) -> FilterState:
        """The state after the step: the new Gaussians, the windows counted since the
        (re)start, the tests' running sums (cleared by an alarm), and step 5's residuals at the
        new mode for the VIF estimate (:mod:`.inflation`)."""
        z = standardised_slip_residuals(mean, block, self.model, self.priors)
        slip_window = block.mask & ~block.at_limit
        dtype = mean.dtype
        slips = jnp.sum(slip_window).astype(dtype)
        excited = jnp.sum(slip_window & (jnp.abs(block.rho) >= self.config.excitation_force))
        limits = jnp.sum(block.mask & block.at_limit).astype(dtype)
        temperature = jnp.sum(jnp.where(slip_window, block.temperature_c, 0.0))

        def since_start(previous, added):
            # A change restart leaves this block out (step 4), a swap keeps it (the challenger
            # took it in).
            return jnp.where(alarm, 0.0, previous) + jnp.where(shifted, 0.0, added)

        up, down = cusum
        return FilterState(
            mean=mean,
            cov=cov,
            time_s=jnp.maximum(block.time_s, state.time_s),
            start_s=jnp.where(alarm, block.time_s, state.start_s),
            n_slip_windows=since_start(state.n_slip_windows, slips),
            n_excited_windows=since_start(state.n_excited_windows, excited.astype(dtype)),
            n_limit_windows=since_start(state.n_limit_windows, limits),
            temperature_sum=since_start(state.temperature_sum, temperature),
            cusum_up=jnp.where(alarm, 0.0, up),
            cusum_down=jnp.where(alarm, 0.0, down),
            challenger_mean=challenger[0],
            challenger_cov=challenger[1],
            log_bayes_factor=jnp.where(alarm, 0.0, swap.log_bayes_factor),
            drive_steps=swap.drive_steps,
            n_alarms=state.n_alarms + alarm.astype(jnp.int32),
            alarm=alarm,
            swap_alarm=swap.swapped,
            inflation=accrue_residuals(state.inflation, z, slip_window),
        )

    def summary(self, state: FilterState) -> OnlineSummary:
        """The estimate of a state (unbatched; vmap for many)."""
        return self.summary_of(self.moments(state))

    def moments(self, state: FilterState) -> StateMoments:
        """What :meth:`summary_of` reads of a state (:func:`~.estimate.state_moments`)."""
        return state_moments(state, self._index, self.config)

    def summary_of(self, moments: StateMoments) -> OnlineSummary:
        """The estimate from a state's :meth:`moments` (unbatched; vmap for many;
        :func:`~.estimate.summary_of`)."""
        return summary_of(moments, self.prior, self.priors, self.config)

    def run(self, state: FilterState, blocks: WindowBlocks) -> OnlineRun:
        """Scan :meth:`update` over blocks (leading axis); returns the last state and every step's
        summary (a trajectory).

        The scan keeps each step's :meth:`moments` and the steps are summarised together after
        it: the summary's many small operations then run once over the trajectory instead of
        once per step.
        """

        def step(carry, block):
            new = self.update(carry, block)
            return new, self.moments(new)

        last, moments = jax.lax.scan(step, state, blocks)
        return OnlineRun(state=last, trajectory=jax.vmap(self.summary_of)(moments))


__all__ = [
    "OnlineEstimator",
    "type_prior",
]
