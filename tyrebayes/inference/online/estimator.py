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
>>> est = OnlineEstimator.create(kind="brush")  # doctest: +SKIP
>>> state = est.init(type_prior(kind="brush"))  # doctest: +SKIP
>>> run = est.run(state, window_blocks(windows))  # doctest: +SKIP
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ..tyre.adequacy import likelier_surface
from ..tyre.model import SURFACES, TyrePriors, check_kind
from .block_likelihood import (
    block_curvature,
    block_log_likelihood,
    standardised_slip_residuals,
)
from .change import cusum_step, predictive_shift_ratios
from .config import OnlineConfig, default_config
from .inflation import accrue_residuals, empty_inflation, inflation_in_use
from .laplace_update import GaussianUpdate, laplace_update
from .parameters import (
    PER_DRIVE,
    PRIOR_CHECKED,
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
    c_x_direction,
    joint_prior_sds,
    log_normal_summary,
    readiness,
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

    >>> estimator = OnlineEstimator.create(kind="magic", surface="dry")
    >>> estimator.kind, estimator.prior.names[:3]
    ('magic', ('log_c_xr', 'temp_sensitivity', 'log_mu_max'))
    >>> state = estimator.init()
    >>> state.mean.shape, float(state.time_s), float(state.n_slip_windows)
    ((11,), 0.0, 0.0)

    :meth:`run` takes it through the steps of a stream (:func:`online_estimate`).
    """

    prior: GaussianPrior
    config: OnlineConfig
    priors: TyrePriors

    @classmethod
    def create(
        cls,
        *,
        kind: str = "magic",
        surface: str = "dry",
        priors: TyrePriors | None = None,
        config: OnlineConfig | None = None,
        imu_gain_log_sd: float = 0.0,
    ) -> OnlineEstimator:
        """An estimator with the type prior of ``priors`` and the stated default settings."""
        check_kind(kind)
        priors = TyrePriors() if priors is None else priors
        prior = type_prior(priors, kind=kind, surface=surface, imu_gain_log_sd=imu_gain_log_sd)
        config = config or default_config(kind, priors.load_sensitive)
        return cls(prior=prior, config=config, priors=priors)

    @property
    def kind(self) -> str:
        return self.prior.kind

    @property
    def _index(self) -> dict:
        return {n: i for i, n in enumerate(self.prior.names)}

    def init(self, prior: GaussianPrior | None = None, time_s=0.0) -> FilterState:
        """The state before any window: the type prior (default this estimator's)."""
        prior = self.prior if prior is None else prior
        if prior.kind != self.kind:
            raise ValueError(f"prior: expected kind {self.kind!r}, got {prior.kind!r}")
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
            return block_log_likelihood(theta, block, weight, self.kind, self.priors)

        def gauss_newton(theta):
            return block_curvature(theta, block, weight, self.kind, self.priors)

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
        z = standardised_slip_residuals(mean, block, self.kind, self.priors)
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
        """What :meth:`summary_of` reads of a state: the part of a summary that needs θ's
        covariance, and the counters."""
        idx = self._index
        mean_temperature = jnp.where(
            state.n_slip_windows > 0,
            state.temperature_sum / jnp.maximum(state.n_slip_windows, 1.0),
            20.0,
        )
        a = c_x_direction(state.mean.shape[0], mean_temperature, idx, state.mean.dtype)
        return StateMoments(
            time_s=state.time_s,
            mean=state.mean,
            sd=jnp.sqrt(jnp.diag(state.cov)),
            log_c_x_mean=a @ state.mean,
            log_c_x_sd=jnp.sqrt(a @ state.cov @ a),
            n_slip_windows=state.n_slip_windows,
            n_excited_windows=state.n_excited_windows,
            n_limit_windows=state.n_limit_windows,
            alarm=state.alarm,
            swap_alarm=state.swap_alarm,
            n_alarms=state.n_alarms,
            log_bayes_factor=state.log_bayes_factor,
            slip_inflation=inflation_in_use(
                state.inflation, self.config.initial_inflation, self.config.inflation_prior_blocks
            ),
        )

    def summary_of(self, moments: StateMoments) -> OnlineSummary:
        """The estimate from a state's :meth:`moments` (unbatched; vmap for many)."""
        idx = self._index
        sd = moments.sd
        c_x = log_normal_summary(moments.log_c_x_mean, moments.log_c_x_sd)
        gain_i, offset_i, c_i = idx["log_force_gain"], idx["slip_offset"], idx["log_c_xr"]
        prior_sds = (moments.mean - self.prior.mean) / jnp.sqrt(jnp.diag(self.prior.cov))
        prior_z = prior_sds[c_i]
        checked = jnp.asarray([n in PRIOR_CHECKED for n in self.prior.names])
        checked_sds = jnp.where(checked, prior_sds, 0.0)
        worst = jnp.argmax(jnp.abs(checked_sds))
        rows = np.asarray([i for i, n in enumerate(self.prior.names) if n in PRIOR_CHECKED])
        joint = joint_prior_sds(
            (moments.mean - self.prior.mean)[rows], self.prior.cov[np.ix_(rows, rows)]
        )
        conflict = (jnp.abs(checked_sds[worst]) > self.config.max_prior_z) | (
            joint > self.config.max_prior_z
        )
        ready, reason = readiness(
            c_x, moments.n_slip_windows, moments.n_excited_windows, prior_z, self.config, conflict
        )
        mu_i = idx["log_mu_max"]
        mu_contraction = 1.0 - sd[mu_i] / jnp.sqrt(self.prior.cov[mu_i, mu_i])
        mu_observed = (moments.n_limit_windows > 0) & (
            mu_contraction >= self.config.mu_observed_contraction
        )
        mu_prior_z = prior_sds[mu_i]
        likelier, label_log_bf = likelier_surface(
            moments.mean[mu_i],
            sd[mu_i],
            self.prior.surface,
            SURFACES,
            jnp.log(self.priors.mu_median(SURFACES)),
            self.priors.mu_log_sd(SURFACES),
        )
        return OnlineSummary(
            time_s=moments.time_s,
            c_x=c_x,
            c_xr=log_normal_summary(moments.mean[c_i], sd[c_i]),
            mu_max=log_normal_summary(moments.mean[mu_i], sd[mu_i]),
            force_gain=log_normal_summary(moments.mean[gain_i], sd[gain_i]),
            slip_offset_mean=moments.mean[offset_i],
            slip_offset_sd=sd[offset_i],
            ready=ready,
            reason=reason,
            mu_observed=mu_observed,
            mu_prior_z=mu_prior_z,
            mu_likelier_surface=likelier.astype(jnp.int32),
            mu_label_log_bf=label_log_bf,
            alarm=moments.alarm,
            swap_alarm=moments.swap_alarm,
            n_alarms=moments.n_alarms,
            swap_log_bayes_factor=moments.log_bayes_factor,
            n_slip_windows=moments.n_slip_windows,
            n_excited_windows=moments.n_excited_windows,
            n_limit_windows=moments.n_limit_windows,
            slip_inflation=moments.slip_inflation,
            prior_conflict=conflict,
            conflict_prior_sds=checked_sds[worst],
            conflict_joint_prior_sds=joint,
            conflict_coordinate=worst.astype(jnp.int32),
            coordinate_names=self.prior.names,
        )

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


#: XLA options the estimator's compiled runs use: XLA's fast math, with NaN, infinities, IEEE
#: division and the library's functions kept as they are. What it leaves on is reassociation,
#: fused multiply-add and the sign of zero: round-off only, so the filter's finiteness checks and
#: safeguards work as written. A Magic Formula car-hour ran 1.07x faster with them, its final
#: mean within 3e-10 posterior sds of the default compilation's, with the same alarms and flags
#: (``benchmarks/results/online_speed.json``, ``compiler_options``); a test compares the two on
#: a linear-model stream.
COMPILER_OPTIONS = {
    "xla_cpu_enable_fast_math": True,
    "xla_cpu_fast_math_honor_nans": True,
    "xla_cpu_fast_math_honor_infs": True,
    "xla_cpu_fast_math_honor_division": True,
    "xla_cpu_fast_math_honor_functions": True,
}


@functools.partial(eqx.filter_jit, compiler_options=COMPILER_OPTIONS)
def run_online(estimator: OnlineEstimator, state: FilterState, blocks: WindowBlocks) -> OnlineRun:
    """:meth:`OnlineEstimator.run`, compiled with :data:`COMPILER_OPTIONS` (once per block shape
    and estimator settings)."""
    return estimator.run(state, blocks)


@functools.partial(eqx.filter_jit, compiler_options=COMPILER_OPTIONS)
def run_online_cars(
    estimator: OnlineEstimator, states: FilterState, blocks: WindowBlocks
) -> OnlineRun:
    """:meth:`OnlineEstimator.run` over many cars in one compiled call: ``states`` and ``blocks``
    carry a leading car axis (vmapped), the trajectory a car axis before its time axis."""
    return jax.vmap(estimator.run)(states, blocks)


def online_estimate(
    blocks: WindowBlocks,
    *,
    kind: str = "magic",
    priors: TyrePriors | None = None,
    config: OnlineConfig | None = None,
    imu_gain_log_sd: float = 0.0,
) -> OnlineRun:
    """Run the estimator from the type prior over one stream's blocks (the command's path).

    Parameters
    ----------
    blocks : WindowBlocks
        The stream's steps (:func:`~.stream.stream_steps`); their surface sets μ_max's prior.
    kind : str
        The tyre-curve model (:data:`~tyrebayes.inference.tyre.curves.MODEL_KINDS`).
    priors : TyrePriors, optional
        The batch model's prior scales (default :class:`TyrePriors`).
    config : OnlineConfig, optional
        Drift, Newton steps, change detection, readiness (default :func:`~.config.default_config`).
    imu_gain_log_sd : float
        Prior sd of the IMU's log gain (0: the gain is known).

    Returns
    -------
    OnlineRun
        The final filter state and the trajectory of summaries, one per step; its ``to_dict()``
        is the estimator's part of ``tyrebayes online --json``.

    Examples
    --------
    The shipped one-minute segment in two steps; the filter's first compilation takes longer
    than a doctest should, so that line is not run here (``tyrebayes online`` runs it):

    >>> from tyrebayes import load_vehicle
    >>> from tyrebayes._resources import data_dir
    >>> from tyrebayes.inference.online import stream_steps, stream_windows
    >>> path = data_dir() / "comma2k19_rav4_segment.csv"
    >>> blocks = stream_steps(stream_windows(path, load_vehicle("suv_rav4")))
    >>> blocks.slip.shape[0], blocks.surface
    (2, 'dry')
    >>> run = online_estimate(blocks)  # doctest: +SKIP
    >>> run.to_dict()["final"]["enough_evidence"]  # doctest: +SKIP
    False
    """
    estimator = OnlineEstimator.create(
        kind=kind,
        surface=blocks.surface,
        priors=priors,
        config=config,
        imu_gain_log_sd=imu_gain_log_sd,
    )
    return run_online(estimator, estimator.init(), blocks)


__all__ = [
    "COMPILER_OPTIONS",
    "OnlineEstimator",
    "online_estimate",
    "run_online",
    "run_online_cars",
    "type_prior",
]
