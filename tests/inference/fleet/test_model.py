"""The fleet model's lateral ratio (tyrebayes.inference.fleet.model): its sites and likelihood."""

import jax
import jax.numpy as jnp
import numpy as np
from numpyro import handlers

from tyrebayes.inference.fleet import fleet_data_from_table, load_tyre_type_priors
from tyrebayes.inference.fleet.fit import _model_args
from tyrebayes.inference.fleet.model import fleet_model, lateral_arrays
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
