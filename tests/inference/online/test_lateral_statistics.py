"""The online lateral estimator's sufficient statistics against the batch model's residuals.

The residuals z · c of the moments' regressors must be the batch lateral model's own (its
:func:`~tyrebayes.inference.lateral.model.residuals`) wherever the model is linear: a tyre curve
with a peak far above the forces (μ_y = 10⁴) has α = ρ/c_y to 1e-8, at any offsets, roll gain,
yaw inertia and steering ratio.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.inference.lateral.model import residuals
from tyrebayes.inference.online.lateral import OnlineLateralEstimator
from tyrebayes.inference.online.lateral_blocks import lateral_blocks
from tyrebayes.inference.online.lateral_statistics import (
    block_moments,
    equation_moments,
    filtered_kinematic_regressors,
    node_weights,
    nominal_axle_forces,
    steering_regressors,
)

from ._cornering import observations

PARAMETERS = {
    "c_y_front": 13.0,
    "c_y_rear": 17.0,
    "steering_ratio": 15.6,
    "steering_offset": 0.02,
    "ay_offset": 0.15,
    "roll_gradient": 0.009,
    "yaw_inertia_factor": 1.1,
}


@pytest.fixture(scope="module")
def drive():
    jax.config.update("jax_enable_x64", True)
    obs, _ = observations("mixed", 3)
    return obs, lateral_blocks(obs)


def _theta(estimator, cubic=1e-30):
    values = {**PARAMETERS, "curve_cubic_front": cubic, "curve_cubic_rear": 0.8 * cubic}
    return jnp.asarray(
        [
            values[n] if n in ("steering_offset", "ay_offset") else np.log(values[n])
            for n in estimator.prior.names
        ]
    )


def test_residuals_are_the_batch_models_in_the_linear_range(drive):
    obs, blocks = drive
    estimator = OnlineLateralEstimator.create(steering_ratio=float(obs.steering_ratio))
    c_s, c_k = estimator.coefficients(_theta(estimator), blocks)
    steer = np.asarray(steering_regressors(blocks, estimator.roll_gain) @ c_s)
    z_k = filtered_kinematic_regressors(blocks, estimator.roll_gain, PARAMETERS["c_y_rear"])
    kin = np.asarray(z_k @ c_k)
    p = {
        **PARAMETERS,
        "mu_y": 1e4,
        **{f"curve_shape_excess_{axle}": 0.34 for axle in ("front", "rear")},
        **{f"curve_curvature_gap_{axle}": 1.6 for axle in ("front", "rear")},
        "relaxation_length": 0.0,
    }
    # Per block, as the estimator cuts them (the kinematic derivative stays within a block).
    batch = [residuals(blocks.block(i), p) for i in range(blocks.n_blocks)]
    mask, mask_k = np.asarray(blocks.mask), np.asarray(blocks.mask_kinematic)
    batch_steer = np.stack([np.asarray(b[0]) for b in batch])
    batch_kin = np.stack([np.asarray(b[1]) for b in batch])
    np.testing.assert_allclose(steer[mask], batch_steer[mask], atol=1e-9)
    np.testing.assert_allclose(kin[mask_k], batch_kin[mask_k], atol=1e-7)


def test_moments_give_the_residuals_sums(drive):
    """Σe², the lag-one products and the 30 s batch means from the moments equal the sums over
    the residuals themselves (the steering equation's samples below the peak share)."""
    _, blocks = drive
    estimator = OnlineLateralEstimator.create()
    c_s, _ = estimator.coefficients(_theta(estimator, cubic=0.3), blocks)
    moments = block_moments(
        blocks, estimator.roll_gain, estimator.force_limit, estimator.rear_nodes
    ).steering
    e = np.asarray(steering_regressors(blocks, estimator.roll_gain) @ c_s)
    used = np.asarray(moments.count).sum()
    assert 0 < used <= np.asarray(blocks.mask).sum()
    gram = np.asarray(moments.gram).sum(axis=0)
    # The samples below the peak share, which the steering equation reads.
    front, rear = (np.asarray(x) for x in nominal_axle_forces(blocks, estimator.roll_gain))
    mask = np.asarray(blocks.mask) & (np.maximum(abs(front), abs(rear)) <= estimator.force_limit)
    assert used == mask.sum()
    c = np.asarray(c_s)
    assert np.isclose(c @ gram @ c, np.sum(e[mask] ** 2), rtol=1e-9)
    pairs = mask[:, 1:] & mask[:, :-1]
    lagged = np.sum(np.where(pairs, e[:, 1:] * e[:, :-1], 0.0))
    assert np.isclose(c @ np.asarray(moments.lagged).sum(axis=0) @ c, lagged, rtol=1e-9)
    block_means = np.asarray([e[i][mask[i]].mean() for i in range(len(e)) if mask[i].sum() >= 150])
    assert np.isclose(np.asarray(moments.batch_total)[:, 1].sum(axis=0) @ c, block_means.sum())
    assert np.isclose(
        c @ np.asarray(moments.batch_gram)[:, 1].sum(axis=0) @ c, np.sum(block_means**2)
    )


@pytest.mark.parametrize("c_y_rear", [9.0, 17.0, 30.0])
def test_kinematic_moments_between_the_nodes_are_the_filtered_ones(drive, c_y_rear):
    """The rear axle's sideslip lag depends on c_r: moments taken at the nodes and interpolated
    in log c_r give the residual sum of squares of regressors filtered at c_r itself."""
    _, blocks = drive
    estimator = OnlineLateralEstimator.create()
    theta = _theta(estimator).at[1].set(np.log(c_y_rear))
    _, c_k = estimator.coefficients(theta, blocks)
    nodes = block_moments(blocks, estimator.roll_gain, estimator.force_limit, estimator.rear_nodes)
    total = jax.tree_util.tree_map(lambda x: x.sum(axis=0), nodes.kinematic)
    mixed = total.mixed(node_weights(theta[1], estimator.rear_nodes))
    z = filtered_kinematic_regressors(blocks, estimator.roll_gain, c_y_rear)
    direct = jax.tree_util.tree_map(
        lambda x: x.sum(axis=0), equation_moments(z, blocks.mask_kinematic)
    )
    c = np.asarray(c_k)
    rss_mixed = c @ np.asarray(mixed.gram) @ c
    rss_direct = c @ np.asarray(direct.gram) @ c
    assert rss_mixed == pytest.approx(rss_direct, rel=2e-3)
