"""A block's likelihood in the online lateral estimator: value, gradient against autodiff, and a
positive semi-definite information."""

import jax
import jax.numpy as jnp
import numpy as np

from tyrebayes.inference.online.lateral import OnlineLateralEstimator
from tyrebayes.inference.online.lateral_blocks import lateral_blocks
from tyrebayes.inference.online.lateral_likelihood import block_information, block_log_likelihood

from ._cornering import observations


def test_block_information_gradient_matches_autodiff():
    obs = observations("mixed", 3)[0]
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
