"""Tests of the shared NUTS engine (tyrebayes.inference.nuts)."""

import logging

import jax
import numpy as np
import numpyro
import numpyro.distributions as dist
import pytest

from tyrebayes.inference.nuts import run_nuts
from tyrebayes.inference.result import diagnose


def _normal_mean(y):
    mu = numpyro.sample("mu", dist.Normal(0.0, 10.0))
    numpyro.sample("y", dist.Normal(mu, 1.0), obs=y)


def test_draws_by_chain_recover_a_conjugate_posterior():
    rng = np.random.default_rng(0)
    y = rng.normal(3.0, 1.0, size=50)
    draws = run_nuts(
        _normal_mean, (y,), seed=1, num_warmup=200, num_samples=300, num_chains=2,
        init_values={"mu": 0.5},
    )  # fmt: skip
    assert draws.samples["mu"].shape == (2, 300)
    assert draws.diverging.shape == (2, 300)
    assert draws.flat()["mu"].shape == (600,)
    # conjugate posterior: mean ≈ ȳ·n/(n + 1/100), sd ≈ 1/√n
    post_sd = 1.0 / np.sqrt(50 + 0.01)
    assert abs(draws.flat()["mu"].mean() - y.mean()) < 4 * post_sd / np.sqrt(100)
    assert 0.8 < draws.flat()["mu"].std() / post_sd < 1.2


def test_the_same_seed_gives_the_same_draws_and_diagnose_reads_them():
    y = np.array([0.3, -0.2, 0.9])
    a = run_nuts(_normal_mean, (y,), seed=7, num_warmup=100, num_samples=100)
    b = run_nuts(_normal_mean, (y,), seed=7, num_warmup=100, num_samples=100)
    np.testing.assert_array_equal(a.samples["mu"], b.samples["mu"])
    import arviz_base as azb

    tree = azb.from_dict({"posterior": a.samples, "sample_stats": {"diverging": a.diverging}})
    assert diagnose(tree, method="nuts").divergences == int(a.diverging.sum())


def test_chains_run_side_by_side_in_equal_groups():
    # conftest gives JAX two CPU devices.
    from tyrebayes.inference.nuts import chains_per_run

    assert [chains_per_run(n) for n in (1, 2, 3, 4)] == [1, 2, 1, 2]


def _compilations(caplog) -> list[str]:
    return [
        r.getMessage()
        for r in caplog.records
        if r.getMessage().startswith("Finished XLA compilation")
    ]


@pytest.mark.parametrize("num_chains", [1, 2])
def test_new_data_of_the_same_shape_reuses_the_compiled_sampler(caplog, num_chains):
    # The data are the program's arguments, not constants in it: a refit compiles nothing.
    rng = np.random.default_rng(num_chains)
    settings = {"num_warmup": 20, "num_samples": 20, "num_chains": num_chains}
    with jax.log_compiles(True), caplog.at_level(logging.WARNING):
        run_nuts(_normal_mean, (rng.normal(size=31),), seed=0, **settings)
        first = _compilations(caplog)
        caplog.clear()
        draws = run_nuts(_normal_mean, (rng.normal(3.0, 1.0, size=31),), seed=1, **settings)
        again = _compilations(caplog)
    assert first and again == []
    assert draws.samples["mu"].shape == (num_chains, 20)
    assert draws.flat()["mu"].mean() > 2.0  # it sampled the new data


@pytest.mark.parametrize("starts", [None, {"mu": np.array([-5.0, 5.0])}])
def test_draws_are_numpyros_for_the_same_key_and_starts(starts):
    # Chain k's key, start and transitions are those of NumPyro's MCMC (parallel chains).
    from numpyro.infer import MCMC, NUTS

    y = np.array([0.3, -0.2, 0.9, 1.4])
    key = jax.random.PRNGKey(5)
    mcmc = MCMC(NUTS(_normal_mean), num_warmup=10, num_samples=10, num_chains=2,
                chain_method="parallel", progress_bar=False)  # fmt: skip
    mcmc.run(key, y, init_params=starts)  # mu is unconstrained: its start is its value
    draws = run_nuts(
        _normal_mean, (y,), seed=key, num_warmup=10, num_samples=10, num_chains=2,
        init_values=starts, init_by_chain=True,
    )  # fmt: skip
    np.testing.assert_allclose(
        draws.samples["mu"], mcmc.get_samples(group_by_chain=True)["mu"], rtol=1e-9, atol=1e-12
    )
