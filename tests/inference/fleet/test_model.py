"""The fleet model (tyrebayes.inference.fleet.model): residual scales, lateral ratio, likelihood."""

import jax
import jax.numpy as jnp
import numpy as np
from numpyro import handlers
from numpyro.infer import Predictive

from tyrebayes.inference.fleet import fleet_data_from_table, load_tyre_type_priors
from tyrebayes.inference.fleet.fit import _model_args
from tyrebayes.inference.fleet.model import _residual_scales, fleet_model, lateral_arrays
from tyrebayes.inference.fleet.priors import prior_arrays
from tyrebayes.simulate.fleet import simulate_fleet

RATIO = {"winter": (0.5, 0.1), "all_season": (0.4, 0.1), "summer": (0.3, 0.1)}


def _trace(table, **substitutes):
    data = fleet_data_from_table(table)
    args = _model_args(data, load_tyre_type_priors())
    model = handlers.substitute(handlers.seed(fleet_model, jax.random.key(0)), data=substitutes)
    return data, handlers.trace(model).get_trace(*args)


def test_without_c_y_the_model_has_no_lateral_sites():
    table, _ = simulate_fleet(2, 12)
    data, tr = _trace(table)
    assert lateral_arrays(data) is None
    assert not {"k_loc", "k_scale", "c_y_obs"} & set(tr)


def test_c_y_observation_is_the_ratio_times_the_latent_stiffness_with_both_errors():
    table, _ = simulate_fleet(2, 12, lateral_ratio=RATIO, lateral_share=0.5)
    k_scale = jnp.array([0.1, 0.2, 0.3])
    data, tr = _trace(table, k_loc_raw=jnp.zeros(3), k_scale=k_scale)
    idx = data.lateral_tyres
    site = tr["c_y_obs"]
    assert site["is_observed"] and site["value"].shape == (idx.size,)
    np.testing.assert_allclose(site["value"], np.log(data.c_y[idx]))
    # k_loc at its prior median: log k_ratio of the set's type
    prior = load_tyre_type_priors()
    t = data.tyre_type[idx]
    log_c = np.asarray(tr["log_c_xr"]["value"])[idx]
    np.testing.assert_allclose(site["fn"].loc, log_c + np.log(prior.k_ratio[t]))
    # the set's own ratio integrated out: population spread and measurement error add
    rel = data.c_y_sd[idx] / data.c_y[idx]
    np.testing.assert_allclose(site["fn"].scale, np.sqrt(np.asarray(k_scale)[t] ** 2 + rel**2))


def test_residual_scales_keep_the_pooled_prior_of_their_definition():
    # log sigma[s,t] = log sigma0[s] + tau[s] z, log sigma0 ~ N(log sigma, sd), tau ~ HalfNormal(h):
    # var log sigma[s,t] = sd^2 + h^2, cov(types) = cov(log sigma0, log sigma[s,t]) = sd^2.
    prior = load_tyre_type_priors()
    p = prior_arrays(prior, np.arange(4))
    draws = Predictive(lambda: _residual_scales(p, 4, 3), num_samples=20000)(jax.random.key(1))
    ls, l0 = np.log(np.asarray(draws["sigma"])), np.log(np.asarray(draws["sigma0"]))
    sd2, h2 = prior.sigma_log_sd**2, prior.tau_sigma**2
    np.testing.assert_allclose(l0.mean(0), np.log(prior.sigma), atol=0.02)
    np.testing.assert_allclose(ls.mean(0), np.log(prior.sigma)[:, None] * np.ones(3), atol=0.03)
    np.testing.assert_allclose(ls.var(0), (sd2 + h2)[:, None] * np.ones(3), rtol=0.05)
    cov_types = np.mean((ls[..., 0] - ls[..., 0].mean(0)) * (ls[..., 2] - ls[..., 2].mean(0)), 0)
    np.testing.assert_allclose(cov_types, sd2, rtol=0.06)
    cov_0 = np.mean((ls[..., 1] - ls[..., 1].mean(0)) * (l0 - l0.mean(0)), 0)
    np.testing.assert_allclose(cov_0, sd2, rtol=0.06)


def test_the_data_do_not_see_sigma0_given_the_types_mean_scale():
    # The divergences sat on the ridge between sigma0 and the per-type scales: the rows must
    # depend on the types' mean log-scale, not on sigma0's own coordinate.
    table, _ = simulate_fleet(3, 24)
    fixed = {"log_sigma_mean": jnp.array([np.log(0.03)]), "tau_sigma": jnp.array([0.3])}
    traces = [_trace(table, sigma0_raw=jnp.array([v]), **fixed)[1] for v in (-2.0, 2.0)]
    ys = [float(jnp.sum(tr["y"]["fn"].log_prob(tr["y"]["value"]))) for tr in traces]
    assert ys[0] == ys[1]
    assert traces[0]["sigma0"]["value"] < traces[1]["sigma0"]["value"]
