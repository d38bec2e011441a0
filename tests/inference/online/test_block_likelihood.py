"""The block log-likelihood's Gauss-Newton curvature: exact value and gradient, and an
information that differs from the exact Hessian by the quantities' own curvature only."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.inference.online import window_blocks
from tyrebayes.inference.online.block_likelihood import (
    _log_likelihood_of,
    block_curvature,
    block_log_likelihood,
)
from tyrebayes.inference.online.laplace_update import laplace_update
from tyrebayes.inference.online.parameters import model_sites, type_prior
from tyrebayes.inference.tyre.model import TyrePriors, window_quantities

from ._synthetic import linear_windows

MODEL = "magic"
PRIORS = TyrePriors()
WEIGHT = jnp.asarray(0.7)


def _block(seconds: float = 30.0, seed: int = 0):
    windows = linear_windows(seed, seconds, c_x=35.0)
    # One step holding all of the windows: 5 s blocks, so the offsets' correction is in it.
    blocks = window_blocks(windows, "dry", width=len(windows), step_s=seconds)
    return jax.tree.map(lambda x: x[0], blocks)


@pytest.fixture(scope="module")
def block():
    return _block()


def _log_likelihood(block):
    return lambda t: block_log_likelihood(t, block, WEIGHT, MODEL, PRIORS)


def test_value_and_gradient_are_the_log_likelihoods(block):
    prior = type_prior(PRIORS, model=MODEL)
    rng = np.random.default_rng(1)
    for theta in (prior.mean, prior.mean + 0.3 * rng.normal(size=prior.mean.shape)):
        theta = jnp.asarray(theta)
        value, gradient, _ = block_curvature(theta, block, WEIGHT, MODEL, PRIORS)
        expected_value, expected_gradient = jax.value_and_grad(_log_likelihood(block))(theta)
        np.testing.assert_allclose(value, expected_value, rtol=1e-12)
        np.testing.assert_allclose(gradient, expected_gradient, rtol=1e-9, atol=1e-9)


def test_information_is_the_hessian_less_the_quantities_curvature(block):
    # ∇²ℓ = Jᵀ∇²F J + Σ ∂F/∂q ∇²q: the second term is the Hessian of θ ↦ ∇F(q₀)·q(θ) with ∇F
    # held at θ₀. The Gauss-Newton information must be −(∇²ℓ − that), to round-off.
    theta = type_prior(PRIORS, model=MODEL).mean
    obs = block.observations(WEIGHT)

    def quantities(t):
        return window_quantities(model_sites(t, MODEL, PRIORS), obs, MODEL)

    q0 = quantities(theta)
    gradient_q = jax.grad(lambda q: _log_likelihood_of(q, block, obs))(q0)

    def linear_in_q(t):
        q = quantities(t)
        return sum(
            jnp.sum(g * x)
            for g, x in zip(jax.tree.leaves(gradient_q), jax.tree.leaves(q), strict=True)
        )

    hessian = jax.hessian(_log_likelihood(block))(theta)
    quantities_curvature = jax.hessian(linear_in_q)(theta)
    _, _, information = block_curvature(theta, block, WEIGHT, MODEL, PRIORS)
    scale = np.sqrt(np.outer(np.abs(np.diag(hessian)), np.abs(np.diag(hessian)))) + 1e-12
    np.testing.assert_allclose(
        (information + (hessian - quantities_curvature)) / scale, 0.0, atol=1e-8
    )
    # ... and the dropped term is not nothing here (far from the mode), so the check has teeth.
    assert np.max(np.abs(quantities_curvature) / scale) > 1e-3


def test_near_the_mode_the_information_on_c_xr_is_the_hessians():
    # Two minutes of windows: the dropped term's weights are residuals, which average out.
    block = _block(120.0, seed=2)
    prior = type_prior(PRIORS, model=MODEL)
    mode = laplace_update(_log_likelihood(block), prior.mean, prior.cov, 30).mean
    exact = -jax.hessian(_log_likelihood(block))(mode)
    _, _, information = block_curvature(mode, block, WEIGHT, MODEL, PRIORS)
    c = prior.names.index("log_c_xr")
    assert float(information[c, c]) == pytest.approx(float(exact[c, c]), rel=0.05)
