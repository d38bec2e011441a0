"""The online estimator: empty steps, vmap over cars, change detection, readiness.

Every run has the same number of steps (padded), so the tests share one compiled filter.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.inference.online import (
    OnlineEstimator,
    default_config,
    pad_steps,
    run_online,
    run_online_cars,
    window_blocks,
)
from tyrebayes.inference.online.process import predict
from tyrebayes.inference.tyre.data import WindowTable
from tyrebayes.inference.tyre.model import TyrePriors

from ._synthetic import linear_windows

pytestmark = pytest.mark.early  # minutes long: started first (tests/conftest.py)

WIDTH = 121
N_STEPS = 41  # 20 minutes of 30 s steps, and one more


@pytest.fixture(scope="module")
def estimator():
    return OnlineEstimator.create(model="linear")


def _steps(windows):
    return pad_steps(window_blocks(windows, "dry", width=WIDTH), N_STEPS)


def test_empty_step_changes_only_the_process(estimator):
    steps = _steps(linear_windows(0, 600.0))  # 20 steps of windows, then empty ones
    state = run_online(estimator, estimator.init(), steps).state
    # The same, with the empty steps 400 s after the last window: only the process model's
    # drift and reversion act.
    later = eqx.tree_at(lambda b: b.time_s, steps, steps.time_s.at[20:].add(400.0))
    moved = run_online(estimator, estimator.init(), later).state
    cfg = estimator.config
    expected_mean, expected = predict(
        estimator.prior, state.mean, state.cov, 400.0, cfg.drift_sd_per_sqrt_s, cfg.reversion_s
    )
    np.testing.assert_allclose(moved.mean, expected_mean, rtol=0, atol=1e-12)
    # Each empty step inverts the covariance twice (eigendecompositions), and an inverse's
    # relative error is up to machine epsilon times the condition number (P's is ~5e5 here).
    # Measured against the entries' scale √(P_ii P_jj), the round-off stays within that bound
    # summed over the inversions.
    scale = np.sqrt(np.outer(np.diag(expected), np.diag(expected)))
    inversions = 2 * (N_STEPS - 20)
    bound = inversions * np.finfo(float).eps * np.linalg.cond(np.asarray(expected))
    np.testing.assert_allclose((moved.cov - expected) / scale, 0.0, atol=bound)
    assert float(moved.n_slip_windows) == float(state.n_slip_windows) == 2400.0


def test_vmap_over_cars_equals_one_car_at_a_time(estimator):
    cars = [_steps(linear_windows(s, 300.0, c_x=30.0 + 10 * s)) for s in range(2)]
    stacked = jax.tree.map(lambda *x: jnp.stack(x), *cars)
    states = jax.tree.map(lambda x: jnp.stack([x, x]), estimator.init())
    run = run_online_cars(estimator, states, stacked)
    final, trajectory = run.state, run.trajectory
    for i, car in enumerate(cars):
        one_run = run_online(estimator, estimator.init(), car)
        one, one_trajectory = one_run.state, one_run.trajectory
        # Batched and single linear algebra round differently (seen: 3e-10 of the covariance's
        # scale, 3e-8 of a posterior sd in a mean): compare in posterior sds.
        sd = np.sqrt(np.diag(one.cov))
        np.testing.assert_allclose((final.mean[i] - one.mean) / sd, 0.0, atol=1e-6)
        scale = np.outer(sd, sd)
        np.testing.assert_allclose((final.cov[i] - one.cov) / scale, 0.0, atol=1e-7)
        np.testing.assert_allclose(trajectory.c_x.mean[i], one_trajectory.c_x.mean, rtol=1e-8)


def test_the_compiler_options_change_round_off_only(estimator):
    # COMPILER_OPTIONS allow reassociation and fused multiply-adds: the filter compiled with
    # XLA's defaults must give the same trajectory to round-off, alarms and flags alike.
    steps = _steps(linear_windows(4, 600.0, c_x=45.0))
    default = eqx.filter_jit(lambda est, state, blocks: est.run(state, blocks))
    plain_run = default(estimator, estimator.init(), steps)
    plain, plain_trajectory = plain_run.state, plain_run.trajectory
    fast_run = run_online(estimator, estimator.init(), steps)
    fast, fast_trajectory = fast_run.state, fast_run.trajectory
    sd = np.sqrt(np.diag(plain.cov))
    np.testing.assert_allclose((fast.mean - plain.mean) / sd, 0.0, atol=1e-6)
    np.testing.assert_allclose(fast.cov / np.outer(sd, sd), plain.cov / np.outer(sd, sd), atol=1e-7)
    np.testing.assert_allclose(fast_trajectory.c_x.mean, plain_trajectory.c_x.mean, rtol=1e-8)
    np.testing.assert_array_equal(fast_trajectory.ready, plain_trajectory.ready)
    np.testing.assert_array_equal(fast_trajectory.alarm, plain_trajectory.alarm)


def test_the_estimate_settles_on_the_truth_and_is_ready(estimator):
    trajectory = run_online(
        estimator, estimator.init(), _steps(linear_windows(3, 600.0))
    ).trajectory
    record = trajectory.to_dict(19)
    assert record["enough_evidence"] and record["reason"] is None
    lo, hi = record["c_x"]["hdi_90"]
    assert lo <= 40.0 <= hi
    assert record["c_x"]["sd"] / record["c_x"]["mean"] < 0.05


def test_gauss_newton_and_exact_curvature_give_the_same_posterior(estimator):
    # The default curvature drops the windows' quantities' own curvature: after 10 minutes the
    # two filters' C_xr must agree to a fraction of a posterior sd, and their sds closely.
    steps = _steps(linear_windows(3, 600.0))
    exact = eqx.tree_at(lambda e: e.config, estimator, default_config("linear", gauss_newton=False))
    assert estimator.config.gauss_newton and not exact.config.gauss_newton
    gauss_newton = run_online(estimator, estimator.init(), steps).state
    hessian = run_online(exact, exact.init(), steps).state
    c = estimator.prior.names.index("log_c_xr")
    sd = float(np.sqrt(hessian.cov[c, c]))
    assert abs(float(gauss_newton.mean[c] - hessian.mean[c])) < 0.1 * sd
    assert float(np.sqrt(gauss_newton.cov[c, c])) == pytest.approx(sd, rel=0.05)


def test_change_fires_on_a_planted_step_and_not_without_one(estimator):
    quiet = run_online(estimator, estimator.init(), _steps(linear_windows(5, 1200.0))).trajectory
    assert int(quiet.n_alarms[-1]) == 0
    swapped = _steps(linear_windows(5, 1200.0, c_x_after=48.0, change_s=600.0))
    loud = run_online(estimator, estimator.init(), swapped).trajectory
    alarms = np.asarray(loud.time_s)[np.asarray(loud.alarm)]
    assert alarms.size >= 1 and 600.0 < alarms[0] <= 900.0
    # Mid-drive, so the change detector's, not the drive-start swap test's.
    assert not np.any(np.asarray(loud.swap_alarm))
    # After the restart from the prior the estimator learns the new tyre.
    assert abs(float(loud.c_x.mean[-1]) / 48.0 - 1.0) < 0.05


@pytest.mark.parametrize("seed", range(4))
def test_one_block_of_outlying_slips_is_not_a_change(estimator, seed):
    # Ten seconds of windows whose slips sit 20 σ off (what a feature error in a tight turn
    # looks like): evidence from one step is capped, so no alarm, and the estimate stays. The
    # Normal errors put the block into the noise scales; reverting to their prior
    # (config.REVERSION_S), they are on their way back 8 minutes later. With constant scales
    # they stayed beyond this bound, and most of these drives raised a false alarm that
    # restarted C_x far from its value (benchmarks/online_outliers.py measures the same on
    # simulated drives).
    windows = linear_windows(seed, 1200.0)
    burst = (windows.time_s > 700.0) & (windows.time_s < 710.0)
    windows = windows.replace(slip=windows.slip + np.where(burst, 20 * 2e-4 * 5, 0.0))
    run = run_online(estimator, estimator.init(), _steps(windows))
    state, trajectory = run.state, run.trajectory
    assert int(trajectory.n_alarms[-1]) == 0
    assert abs(float(trajectory.c_x.mean[-1]) / 40.0 - 1.0) < 0.05
    noise = np.asarray(["noise_scale" in n for n in estimator.prior.names])
    prior_sds = (state.mean - estimator.prior.mean) / jnp.sqrt(jnp.diag(estimator.prior.cov))
    assert np.all(np.abs(np.asarray(prior_sds)[noise]) < 6.0)


def _two_drives(seed, c_x_after, offset_after):
    """A 10-minute drive, then a 10-minute one on a tyre of C_x ``c_x_after`` with its own slip
    offset (the car stood between them)."""
    first = linear_windows(seed, 600.0)
    second = linear_windows(seed + 1, 600.0, c_x=c_x_after, slip_offset=offset_after, start_s=600.0)
    first = first.replace(drive=np.zeros(len(first), dtype=np.int64))
    second = second.replace(drive=np.ones(len(second), dtype=np.int64))
    return WindowTable.concatenate([first, second])


def test_swap_at_a_drive_start_is_found_and_a_new_drive_alone_is_not(estimator):
    # A new drive with a new slip offset on the same tyre: the per-drive coordinates restart,
    # and neither detector fires.
    same = _steps(_two_drives(11, 40.0, -0.003))
    assert bool(same.drive_start[20]) and int(np.sum(np.asarray(same.drive_start))) == 2
    quiet = run_online(estimator, estimator.init(), same).trajectory
    assert int(quiet.n_alarms[-1]) == 0
    assert float(np.max(quiet.swap_log_bayes_factor)) < estimator.config.swap_threshold
    # The same, on a tyre 30 % stiffer: the swap test (alone: the mid-drive CUSUM switched off)
    # fires within 5 minutes of the new drive, and the estimate is the challenger's, which
    # learned the new tyre from the drive start.
    swap_only = OnlineEstimator.create(
        model="linear", config=default_config("linear", change_threshold=float("inf"))
    )
    loud = run_online(swap_only, swap_only.init(), _steps(_two_drives(11, 52.0, -0.003))).trajectory
    alarms = np.asarray(loud.time_s)[np.asarray(loud.alarm)]
    assert alarms.size == 1 and 600.0 < alarms[0] <= 900.0
    assert np.array_equal(np.asarray(loud.swap_alarm), np.asarray(loud.alarm))
    assert abs(float(loud.c_x.mean[-1]) / 52.0 - 1.0) < 0.03


def test_not_ready_without_excitation(estimator):
    # Forces that never leave the noise band: many windows, and no evidence of a slope.
    windows = linear_windows(7, 600.0, force_range=(0.02, 0.045))
    trajectory = run_online(estimator, estimator.init(), _steps(windows)).trajectory
    record = trajectory.to_dict(19)
    assert not record["enough_evidence"]
    assert record["c_x"] is None and record["c_xr"] is None
    assert "excitation" in record["reason"]
    assert record["mu_max"] is None and "not observed" in record["mu_max_reason"]


def test_load_sensitivity_is_tracked_where_the_priors_have_it():
    """With the measured tyres' prior on q the filter carries it as θ's last coordinate and
    reads a load sensitivity of 0.8 hidden in the windows; C_x is the static load's."""
    estimator = OnlineEstimator.create(model="linear", priors=TyrePriors().with_load_sensitivity())
    assert estimator.prior.names[-1] == "load_sensitivity"
    windows = linear_windows(3, 600.0, load_sensitivity=0.8)
    run = run_online(estimator, estimator.init(), _steps(windows))
    state, trajectory = run.state, run.trajectory
    q, q_sd = float(state.mean[-1]), float(np.sqrt(state.cov[-1, -1]))
    assert abs(q - 0.8) < 1.645 * q_sd and q_sd < 0.15
    lo, hi = trajectory.to_dict(19)["c_x"]["hdi_90"]
    assert lo <= 40.0 <= hi


def test_other_settings_reuse_the_compiled_filter(estimator, caplog):
    # The settings are values the compiled filter takes: changing them compiles nothing.
    import logging

    steps = _steps(linear_windows(3, 300.0))
    default = run_online(estimator, estimator.init(), steps).trajectory  # compiled for this shape
    lax = OnlineEstimator.create(
        model="linear",
        config=default_config(
            "linear", ready_half_width=100.0, min_slip_windows=0, min_excited_windows=0
        ),
    )
    caplog.clear()
    with jax.log_compiles(True), caplog.at_level(logging.WARNING):
        trajectory = run_online(lax, lax.init(), steps).trajectory
    messages = [r.getMessage() for r in caplog.records]
    assert not [m for m in messages if m.startswith("Finished XLA compilation")]
    # ... and it read them: with no evidence asked for, the first step is "ready".
    assert not bool(default.ready[0]) and bool(trajectory.ready[0])


def _with_abs_stop(windows: WindowTable, at_s: float, mu: float) -> WindowTable:
    """``windows`` with 2.5 s of ABS windows at ``at_s``: the braking force at the peak μ."""
    inside = (windows.time_s >= at_s) & (windows.time_s < at_s + 2.5)
    rng = np.random.default_rng(3)
    rho = windows.rho.copy()
    rho[inside] = -mu + rng.normal(0.0, 0.02 * mu, inside.sum())
    return windows.replace(rho=rho, at_limit=windows.at_limit | inside)


@pytest.mark.parametrize("surface", ["dry", "ice"])
def test_a_dry_road_labelled_ice_is_not_reported_as_such(estimator, surface):
    # A hidden effect: a road of μ 0.9 (two ABS stops) under a label whose prior puts μ_max near
    # 0.12. The estimator must not report a μ_max for that label without a note, nor a C_x and
    # μ_max from a tyre its type prior does not allow; labelled dry, it reports both. (Each
    # label compiles its own filter; the snow label's note is test_summary.py's.)
    if surface != "dry":  # labelled dry, the module's filter (compiled once) serves
        estimator = OnlineEstimator.create(model="linear", surface=surface)
    windows = _with_abs_stop(_with_abs_stop(linear_windows(11, 600.0), 200.0, 0.9), 400.0, 0.9)
    blocks = window_blocks(windows, surface, width=WIDTH)
    trajectory = run_online(estimator, estimator.init(), pad_steps(blocks, N_STEPS)).trajectory
    record = trajectory.to_dict(blocks.n_blocks - 1)  # the drive's last step
    if surface == "dry":
        assert record["mu_max"] is not None and record["mu_max_note"] is None
        assert record["prior_conflict"] is None and record["enough_evidence"]
        assert record["mu_max"]["hdi_90"][0] < 0.9 / 0.97 < record["mu_max"]["hdi_90"][1] * 1.1
    else:
        assert record["mu_max_note"] is not None or (
            record["mu_max"] is None and record["prior_conflict"] is not None
        ), record


def test_create_refuses_the_old_curve_keyword_naming_model():
    with pytest.raises(TypeError, match="create: keyword 'kind' is now 'model'"):
        OnlineEstimator.create(kind="linear")
