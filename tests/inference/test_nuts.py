"""Tests of the shared NUTS engine (tyrebayes.inference.nuts)."""

import numpy as np
import numpyro
import numpyro.distributions as dist

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
