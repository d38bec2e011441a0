"""A drive's online lateral run as the command prints it: null with the reason until the
understeer gradient is identified, then the estimate's object."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from tyrebayes.inference.online.lateral import OnlineLateralEstimator
from tyrebayes.inference.online.lateral_run import LateralRun
from tyrebayes.inference.online.lateral_summary import LateralTrajectory


def _run(estimator, state) -> LateralRun:
    trajectory = LateralTrajectory(
        time_s=state.time_s[None],
        log_c_y_mean=state.mean[None, :2],
        log_c_y_cov=state.cov[None, :2, :2],
        vif_settled=state.vif_settled()[None],
    )
    return LateralRun(estimate=estimator.result(state), trajectory=trajectory)


def test_prior_is_null_with_the_reason():
    est = OnlineLateralEstimator.create()
    out = _run(est, est.init()).to_dict()
    assert list(out) == ["lateral_reason", "lateral"]
    assert out["lateral"] is None and out["lateral_reason"].startswith("lateral: not yet")


def test_identified_gives_the_estimate_object():
    est = OnlineLateralEstimator.create()
    state = est.init()
    cov = np.asarray(state.cov).copy()
    cov[:2, :2] = 0.01**2 * np.eye(2)
    state = eqx.tree_at(
        lambda s: (s.cov, s.batches_30s),
        state,
        (jnp.asarray(cov), jnp.full(2, 8.0)),
    )
    run = _run(est, state)
    out = run.to_dict()
    assert out["lateral_reason"] == "" and out["lateral"] == run.estimate.to_dict()
    assert out["lateral"]["ready"]
