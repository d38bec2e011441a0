"""The process model: drift and reversion of θ between steps."""

import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.inference.online import default_config
from tyrebayes.inference.online.parameters import type_prior
from tyrebayes.inference.online.process import predict

PRIOR = type_prior(model="linear")
CONFIG = default_config("linear")
NOISE = np.asarray(["noise_scale" in n for n in PRIOR.names])


def _settled():
    """A posterior far from the prior: every coordinate 3 prior sds out, variances 1 % of it."""
    sd = jnp.sqrt(jnp.diag(PRIOR.cov))
    return PRIOR.mean + 3.0 * sd, jnp.diag((0.1 * sd) ** 2)


def _predict(mean, cov, seconds):
    return predict(PRIOR, mean, cov, seconds, CONFIG.drift_sd_per_sqrt_s, CONFIG.reversion_s)


def test_only_the_noise_scales_revert_and_the_rest_only_drifts():
    assert NOISE.sum() == 2 and np.all(np.isfinite(np.asarray(CONFIG.reversion_s)) == NOISE)
    mean, cov = _settled()
    moved_mean, moved_cov = _predict(mean, cov, 300.0)
    np.testing.assert_array_equal(np.asarray(moved_mean)[~NOISE], np.asarray(mean)[~NOISE])
    fixed = ~NOISE[:, None] & ~NOISE[None, :]
    drift = jnp.diag(CONFIG.drift_sd_per_sqrt_s**2 * 300.0)
    np.testing.assert_array_equal(np.asarray(moved_cov)[fixed], np.asarray(cov + drift)[fixed])


def test_a_noise_scale_relaxes_to_its_prior_with_its_correlation_time():
    mean, cov = _settled()
    tau = float(CONFIG.reversion_s[NOISE][0])
    half_mean, half_cov = _predict(mean, cov, tau * np.log(2.0))
    offset = np.asarray(half_mean - PRIOR.mean)[NOISE]
    np.testing.assert_allclose(offset, 0.5 * np.asarray(mean - PRIOR.mean)[NOISE], rtol=1e-12)
    # The variance: a² of the old plus (1 − a²) of the prior's.
    expected = 0.25 * np.diag(cov)[NOISE] + 0.75 * np.diag(PRIOR.cov)[NOISE]
    np.testing.assert_allclose(np.diag(half_cov)[NOISE], expected, rtol=1e-12)
    # Long after, the marginal is the prior's.
    far_mean, far_cov = _predict(mean, cov, 100 * tau)
    np.testing.assert_allclose(
        np.asarray(far_mean)[NOISE], np.asarray(PRIOR.mean)[NOISE], atol=1e-12
    )
    np.testing.assert_allclose(np.diag(far_cov)[NOISE], np.diag(PRIOR.cov)[NOISE])


def test_two_predictions_are_one_over_their_sum():
    # The exact transition of the process: moving 100 s then 250 s is moving 350 s.
    mean, cov = _settled()
    cov = cov + 0.5 * jnp.outer(jnp.sqrt(jnp.diag(cov)), jnp.sqrt(jnp.diag(cov)))  # correlated
    twice = _predict(*_predict(mean, cov, 100.0), 250.0)
    once = _predict(mean, cov, 350.0)
    np.testing.assert_allclose(twice[0], once[0], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(twice[1], once[1], rtol=1e-10, atol=1e-18)


def test_the_prior_is_stationary_for_the_reverting_coordinates():
    moved_mean, moved_cov = _predict(PRIOR.mean, PRIOR.cov, 1234.0)
    np.testing.assert_allclose(moved_mean, PRIOR.mean, rtol=0, atol=1e-15)
    both = NOISE[:, None] & NOISE[None, :]
    np.testing.assert_allclose(np.asarray(moved_cov)[both], np.asarray(PRIOR.cov)[both])


@pytest.mark.parametrize(
    "changes",
    [
        {"reversion_s": jnp.zeros(len(PRIOR.names))},
        {"reversion_s": jnp.full(len(PRIOR.names), jnp.nan)},
        {"reversion_s": jnp.ones(3)},
        {"drift_sd_per_sqrt_s": -jnp.ones(len(PRIOR.names))},
    ],
)
def test_a_process_that_cannot_be_is_refused(changes):
    # Mismatched shapes meet jaxtyping's check first where it is on (the test suite).
    with pytest.raises((ValueError, TypeError), match="OnlineConfig"):
        default_config("linear", **changes)
