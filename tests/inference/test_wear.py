"""Tests of the wear inference: gamma recovery, the extension switched off, predictions, warning."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from numpyro.handlers import condition, seed, trace
from numpyro.infer.util import log_density

from tyrebayes._errors import BadInputError
from tyrebayes.decisions import high_wear_warning
from tyrebayes.inference.result import load_fit
from tyrebayes.inference.wear import (
    WearPriors,
    WearSet,
    build_wear_data,
    c_xr_lognormal,
    fit_wear,
    gamma_summary,
    predict_wear_volume,
    relative_wear_draws,
    wear_model,
)
from tyrebayes.physics.wear import Abrasability
from tyrebayes.simulate.wear import (
    DutyProfile,
    observe_wear,
    profile_kernel,
    seasonal_ambient,
    simulate_drives,
)

GAMMA_TRUE = 0.05  # mm^3/J
PROFILE = DutyProfile(drive_duration_s=1800.0, dt_s=6.0)


@pytest.fixture(scope="module")
def simulated():
    key = jax.random.PRNGKey(11)
    n = 100
    amb = seasonal_ambient(key, jnp.linspace(0.0, 365.0, n))
    work = simulate_drives(key, n, amb, 35.0, Abrasability(GAMMA_TRUE), PROFILE)
    obs = observe_wear(jax.random.PRNGKey(12), work, jnp.arange(0.0, 3100.0, 1000.0), 0.05, 2e-4)
    return work, obs


@pytest.fixture(scope="module")
def depth_fit(simulated):
    work, obs = simulated
    data = build_wear_data([WearSet.from_c_xr(work, obs, "summer", (35.0, 1.5))], use_drift=False)
    return fit_wear(data, extended=False, num_warmup=120, num_samples=200, num_chains=1, seed=1)


def test_gamma_recovered_from_tread_depth(depth_fit):
    s = gamma_summary(depth_fit)[0]
    lo, hi = s["hdi_90"]
    # one fixed-key data set: truth inside the 90 % interval, posterior mean within 15 %
    assert lo < GAMMA_TRUE < hi
    assert abs(s["mean"] / GAMMA_TRUE - 1) < 0.15
    assert depth_fit.kind == "wear" and depth_fit.diagnostics.divergences == 0
    assert "depth" in depth_fit.data["log_likelihood"]


def test_saved_wear_fit_loads_back_and_predicts_the_same(depth_fit, tmp_path):
    loaded = load_fit(depth_fit.save(tmp_path / "wear.nc"), kind="wear")
    np.testing.assert_equal(loaded.diagnostics.as_dict(), depth_fit.diagnostics.as_dict())
    assert loaded.provenance.model == "baseline"
    k, grid = profile_kernel(jax.random.PRNGKey(5), 15.0, 1000.0, PROFILE, n_drives=2)
    np.testing.assert_allclose(
        predict_wear_volume(loaded, k, grid, set_index=0),
        predict_wear_volume(depth_fit, k, grid, set_index=0),
    )
    with pytest.raises(BadInputError, match="expected a fleet fit, got a wear fit"):
        load_fit(tmp_path / "wear.nc", kind="fleet")


def test_too_short_a_run_is_reported_not_converged(simulated):
    work, obs = simulated
    data = build_wear_data([WearSet.from_c_xr(work, obs, "summer", (35.0, 1.5))], use_drift=False)
    fit = fit_wear(data, num_warmup=10, num_samples=10, num_chains=2, seed=2)
    assert not fit.converged
    assert any("ESS" in r for r in fit.diagnostics.reasons), fit.diagnostics.reasons


def test_extension_with_kappa_zero_reproduces_baseline_exactly(simulated):
    work, obs = simulated
    data = build_wear_data([WearSet.from_c_xr(work, obs, "winter", (35.0, 1.5))])
    params = {
        "mu_log_gamma": jnp.array([np.log(0.05)]),
        "log_c_xr": jnp.log(jnp.array([34.0])),
        "radius_offset_permille": jnp.array([0.1]),
        "initial_depth_mm": jnp.array([[8.1], [7.9]]),
        "sigma_depth_mm": jnp.array(0.1),
        "sigma_radius_permille": jnp.array(0.2),
    }
    base, _ = log_density(wear_model, (data, False), {}, params)
    ext, _ = log_density(wear_model, (data, True), {}, {**params, "kappa": jnp.zeros(1)})
    # the extended joint has one more prior term, log N(0 | 0, kappa_sd); the likelihoods agree
    prior_kappa = -0.5 * np.log(2 * np.pi) - np.log(WearPriors().kappa_sd_per_k)
    assert float(ext) == pytest.approx(float(base) + prior_kappa, rel=1e-13)
    tr_b = trace(seed(condition(wear_model, params), 0)).get_trace(data, False)
    tr_e = trace(seed(condition(wear_model, {**params, "kappa": jnp.zeros(1)}), 0)).get_trace(
        data, True
    )
    for site in ("depth", "drift_permille"):
        np.testing.assert_array_equal(tr_b[site]["fn"].loc, tr_e[site]["fn"].loc)


def test_c_xr_input_forms():
    m, s = c_xr_lognormal((40.0, 4.0))
    # log-normal with mean 40 and sd 4: log-sd = sqrt(log(1.01))
    assert s == pytest.approx(np.sqrt(np.log(1.01)), rel=1e-12)
    assert np.exp(m + s**2 / 2) == pytest.approx(40.0, rel=1e-12)
    draws = np.exp(np.random.default_rng(0).normal(np.log(40.0), 0.1, 4000))
    m2, s2 = c_xr_lognormal(draws)
    assert m2 == pytest.approx(np.log(40.0), abs=0.01)
    assert s2 == pytest.approx(0.1, abs=0.01)
    with pytest.raises(ValueError, match="c_xr"):
        c_xr_lognormal((-1.0, 2.0))


def test_build_rejects_bad_input(simulated):
    work, obs = simulated
    # A tuple is not a WearSet: the type check at test time (or the function itself) says so.
    with pytest.raises((TypeError, ValueError), match="WearSet"):
        build_wear_data([(work, obs, "summer", (35.0, 1.0))])
    work, obs = simulated
    with pytest.raises(ValueError, match="use_depth or use_drift"):
        build_wear_data(
            [WearSet.from_c_xr(work, obs, "summer", (35.0, 1.0))], use_depth=False, use_drift=False
        )
    with pytest.raises(ValueError, match="tyre_type"):
        build_wear_data(
            [WearSet.from_c_xr(work, obs, "slick", (35.0, 1.0))], type_names=("summer",)
        )


def test_predictions_relative_wear_and_warning(depth_fit):
    k_cold, grid = profile_kernel(jax.random.PRNGKey(5), 5.0, 1000.0, PROFILE, n_drives=4)
    k_hot, _ = profile_kernel(jax.random.PRNGKey(5), 35.0, 1000.0, PROFILE, n_drives=4)
    cold = predict_wear_volume(depth_fit, k_cold, grid, set_index=0)
    hot = predict_wear_volume(depth_fit, k_hot, grid, set_index=0)
    assert cold.shape == (200, 2)
    assert bool(np.all(cold > 0))
    # baseline model: heat only acts through C_x(T), the tyre is softer -> more slip work
    rel = relative_wear_draws(hot[:, 0], cold[:, 0])
    assert 1.0 < rel["i_rel"]["mean"] < 1.6
    new = predict_wear_volume(depth_fit, k_cold, grid, type_name="summer", c_xr=(35.0, 1.5))
    assert new.shape == (200, 2)
    with pytest.raises(ValueError, match="c_xr"):
        predict_wear_volume(depth_fit, k_cold, grid, type_name="summer")


def test_warning_and_relative_forms_by_hand():
    a = np.full(100, 3.0)
    b = np.full(100, 2.0)
    rel = relative_wear_draws(a, b)
    assert rel["i_rel"]["mean"] == pytest.approx(1.5)
    assert rel["i_rel_thesis"]["mean"] == pytest.approx(1 / 3)
    w = high_wear_warning(rel["draws"], threshold=1.25)
    assert w.warning and w.probability == 1.0
    assert "unexpectedly high wear" in w.message
    ratio = np.concatenate([np.full(70, 1.3), np.full(30, 1.1)])
    w2 = high_wear_warning(ratio, threshold=1.25, decision_probability=0.8)
    assert not w2.warning and w2.probability == pytest.approx(0.7)
