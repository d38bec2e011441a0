"""The online lateral estimate's readiness rule: K alone along a ridge, front and rear once the
level narrows, nothing from the prior alone."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from tyrebayes.inference.online.lateral import OnlineLateralEstimator


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
        lambda s: s.batches_30s,
        state,
        jnp.full(2, 8.0),
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
