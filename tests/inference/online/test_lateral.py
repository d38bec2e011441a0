"""The online lateral estimator: a simulated replay against the batch fit, the "not yet" case,
its block likelihood against autodiff.

Every replay is 300 s (10 blocks of 30 s), so the tests share one compiled run.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import cornering_observations, fit_lateral
from tyrebayes.inference.online.lateral import (
    OnlineLateralEstimator,
    block_information,
    block_log_likelihood,
    online_lateral,
)
from tyrebayes.inference.online.lateral_blocks import lateral_blocks
from tyrebayes.simulate.cornering import simulate_cornering
from tyrebayes.streams import validate_stream

pytestmark = pytest.mark.early  # compiles the estimator (tens of seconds)

DURATION_S = 300.0


def _observations(kind: str, seed: int, duration_s: float = DURATION_S):
    vehicle = load_vehicle("compact_fwd")
    frame, truth = simulate_cornering(vehicle, kind=kind, duration_s=duration_s, seed=seed)
    return cornering_observations(validate_stream(frame, vehicle).data, vehicle), truth


@pytest.fixture(scope="module")
def mixed():
    obs, truth = _observations("mixed", 3)
    result, trajectory = online_lateral(lateral_blocks(obs))
    return obs, truth, result, trajectory


def test_mixed_replay_is_ready_and_agrees_with_the_batch_fit(mixed):
    obs, truth, result, trajectory = mixed
    assert result.k_identified and result.split_identified
    online = result.to_dict()
    assert online["ready"] and online["reason"] == ""
    batch = fit_lateral(obs).to_dict()
    for key in ("c_y_front", "c_y_rear", "understeer_gradient"):
        assert set(online[key]) == {"mean", "sd", "hdi_90"}
        # Stated tolerance: within two batch sds of the batch mean (the benchmark's figure
        # counts one), and the truth inside the online 90 % interval.
        gap = abs(online[key]["mean"] - batch[key]["mean"]) / batch[key]["sd"]
        assert gap <= 2.0, (key, gap)
        lo, hi = online[key]["hdi_90"]
        assert lo <= getattr(truth, key) <= hi, key
    # The trajectory narrows: the last block's c_y sd below the first's.
    sd = np.asarray(trajectory.estimates()["c_y_front"]["sd"])
    assert trajectory.time_s.shape == (10,) and sd[-1] < sd[0]


def test_a_ridge_along_the_axle_level_reports_the_gradient_only():
    """Steady cornering's posterior: K = (1/c_f − 1/c_r)/g tight, the axles' common level wide.
    The rule reports K and withholds c_y front and rear, saying why."""
    est = OnlineLateralEstimator.create()
    state = est.init()
    c_f, c_r = 14.0, 18.0
    # log c_y of both axles moving together by a common factor e^s changes 1/c_f − 1/c_r by
    # (1/c_f − 1/c_r)(e^(−s) − 1): the ridge direction in (x_f, x_r) is (1, 1); K's gradient
    # is (−1/c_f, 1/c_r)/g. Level sd 0.3 (above half the prior's 0.5), K's direction narrow.
    ridge = np.asarray([1.0, 1.0]) / np.sqrt(2.0)
    across = np.asarray([1.0, -1.0]) / np.sqrt(2.0)
    block = 0.3**2 * 2 * np.outer(ridge, ridge) + 0.005**2 * np.outer(across, across)
    cov = np.asarray(state.cov).copy()
    cov[:2, :2] = block
    mean = np.asarray(state.mean).copy()
    mean[:2] = np.log([c_f, c_r])
    state = eqx.tree_at(
        lambda s: (s.steering.batches, s.kinematic.batches),
        state,
        (jnp.full(3, 8.0), jnp.full(3, 8.0)),
    )
    ridge_state = eqx.tree_at(
        lambda s: (s.mean, s.cov), state, (jnp.asarray(mean), jnp.asarray(cov))
    )
    result = est.result(ridge_state)
    assert result.k_identified and not result.split_identified
    d = result.to_dict()
    assert d["c_y_front"] is None and d["c_y_rear"] is None and not d["ready"]
    assert d["understeer_gradient_ready"] and "front from rear" in d["reason"]
    assert set(d["understeer_gradient"]) == {"mean", "sd", "hdi_90"}
    # Narrow the level as well: front and rear are told apart.
    cov[:2, :2] = 0.05**2 * 2 * np.outer(ridge, ridge) + 0.005**2 * np.outer(across, across)
    told = est.result(eqx.tree_at(lambda s: s.cov, ridge_state, jnp.asarray(cov)))
    assert told.split_identified and told.to_dict()["c_y_front"] is not None


def test_prior_alone_is_not_yet():
    est = OnlineLateralEstimator.create()
    d = est.result(est.init()).to_dict()
    assert d["understeer_gradient"] is None and d["c_y_front"] is None
    assert d["reason"].startswith("lateral: not yet")


def test_braking_samples_are_left_out(mixed):
    obs = mixed[0]
    blocks = lateral_blocks(obs, max_longitudinal_mps2=0.3)
    ax = np.asarray(blocks.ax)
    mask = np.asarray(blocks.mask)
    assert not mask[np.abs(ax) > 0.3].any()
    assert (
        float(blocks.n_skipped.sum())
        == (
            np.asarray(obs.mask) & (np.abs(np.gradient(np.asarray(obs.speed), obs.dt_s)) > 0.3)
        ).sum()
    )
    assert not np.asarray(blocks.mask_kinematic)[:, [0, 1, -2, -1]].any()
    with pytest.raises(ValueError, match="step_s: expected a whole number"):
        lateral_blocks(obs, step_s=0.55)


def test_block_information_gradient_matches_autodiff(mixed):
    obs = mixed[0]
    block = lateral_blocks(obs).block(3)
    est = OnlineLateralEstimator.create()
    theta = est.prior.mean + 0.05
    weights = jnp.asarray([0.3, 0.2])
    names = est.prior.names
    value, gradient, information = block_information(theta, block, weights, names, est.priors)
    np.testing.assert_allclose(
        value, block_log_likelihood(theta, block, weights, names, est.priors), rtol=1e-10
    )
    auto = jax.grad(block_log_likelihood)(theta, block, weights, names, est.priors)
    np.testing.assert_allclose(gradient, auto, rtol=1e-7, atol=1e-7 * float(jnp.max(abs(auto))))
    eig = np.linalg.eigvalsh(np.asarray(information))
    assert eig.min() >= -1e-8 * eig.max()


def test_residual_vif_follows_the_batch_rule():
    from tyrebayes.inference.lateral.inflation import residual_inflation
    from tyrebayes.inference.online.lateral import INITIAL_VIF, VIF_PRIOR_CHUNKS, ResidualMoments

    rng = np.random.default_rng(0)
    phi, n = 0.8, 20 * 300
    x = np.zeros(n)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + rng.normal()
    moments = ResidualMoments.empty(jnp.float64)
    for block in x.reshape(20, 300):
        moments = moments.add(jnp.asarray(block), jnp.ones(300, bool))
    batch = residual_inflation(x, np.ones(n, bool))
    seen = n / 100
    expected = (VIF_PRIOR_CHUNKS * INITIAL_VIF + seen * batch) / (VIF_PRIOR_CHUNKS + seen)
    # Stated tolerance: 15 % (clock batches and the batch fit's compacted ones differ slightly).
    assert abs(float(moments.inflation()) / expected - 1.0) < 0.15
    assert int(moments.batches[2]) == 10  # ten 60 s batches from twenty 30 s blocks
