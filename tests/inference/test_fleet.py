"""Tests of the hierarchical fleet model (tyrebayes.inference.fleet)."""

import numpy as np
import pandas as pd
import pytest

from tyrebayes._domain import SURFACES, TYRE_TYPES
from tyrebayes._errors import BadInputError
from tyrebayes.inference.fleet import (
    fit_fleet,
    fit_summary,
    fleet_data_from_table,
    load_tyre_type_priors,
    measured_braking_bounds,
    predict_friction,
    predictive_logpdf,
    prior_predictive_check,
    type_probabilities,
)
from tyrebayes.inference.result import load_fit
from tyrebayes.simulate.fleet import TYPE_FRICTION, simulate_fleet


@pytest.fixture(scope="module")
def fit120():
    """One NUTS fit of a simulated 120-set snow fleet (type mix 40/30/30 %), shared by tests."""
    table, truth = simulate_fleet(
        11, 120, type_shares={"winter": 0.4, "all_season": 0.3, "summer": 0.3}
    )
    fit = fit_fleet(table, seed=3, num_chains=2)  # the default sampler settings
    return table, truth, fit


# --- priors -------------------------------------------------------------------------------------


def test_priors_load_and_match_thesis_ranges():
    p = load_tyre_type_priors()
    assert p.c_xr_ref.tolist() == [30.0, 40.0, 55.0]  # thesis Fig 6.1 ranges 25-35 / 45-65
    assert p.mu.shape == (len(SURFACES), len(TYRE_TYPES))
    snow = SURFACES.index("snow")
    assert p.mu[snow, 0] > p.mu[snow, 1] > p.mu[snow, 2]  # winter > all-season > summer on snow
    assert p.slope[snow] > 0  # softer grips better (thesis Fig 6.1)


def test_prior_predictive_consistent_with_every_measured_braking_row():
    check = prior_predictive_check(n_draws=4000, seed=0)
    assert len(check) == len(measured_braking_bounds()) == 24
    bad = check.loc[~check["consistent"], ["source", "tyre_type", "surface"]]
    assert bad.empty, bad.to_string()
    # The summer-on-snow row is an upper bound (What Car?: > twice the winter distance).
    summer_snow = check[(check.tyre_type == "summer") & (check.surface == "snow")]
    assert (summer_snow["bound"] == "upper").all()


# --- bad tables ---------------------------------------------------------------------------------


def _table(**overrides):
    table, _ = simulate_fleet(0, 12)
    for col, value in overrides.items():
        table[col] = value
    return table


def test_unknown_tyre_type_rejected():
    table = _table()
    table.loc[0, "tyre_type"] = "racing"
    with pytest.raises(BadInputError, match=r"tyre_type: expected one of .*'racing'"):
        fleet_data_from_table(table)


def test_missing_c_xr_column_and_missing_value_rejected():
    with pytest.raises(BadInputError, match=r"missing \['c_xr'\]"):
        fleet_data_from_table(_table().drop(columns="c_xr"))
    table = _table()
    table.loc[3, "c_xr"] = np.nan
    with pytest.raises(BadInputError, match="c_xr: expected a finite stiffness"):
        fleet_data_from_table(table)


def test_negative_stiffness_rejected():
    table = _table()
    table.loc[2, "c_xr"] = -30.0
    with pytest.raises(BadInputError, match="c_xr: expected positive stiffness, got minimum -30"):
        fleet_data_from_table(table)


def test_implausible_stiffness_and_percent_friction_rejected_by_the_library():
    # the range checks live with the table's other checks, so every caller (command, fleet run)
    # gets them, not only fit-fleet
    table = _table()
    table.loc[4, "c_xr"] = 3500.0  # a unit slip (N/unit slip instead of normalised)
    with pytest.raises(BadInputError, match=r"c_xr: expected a stiffness in \[1, 1000\].*3500"):
        fleet_data_from_table(table)
    table = _table()
    table["mu"] = table["mu"] * 100.0
    with pytest.raises(BadInputError, match=r"mu: expected a friction coefficient.*percent"):
        fleet_data_from_table(table)
    # without an outcome (prediction tables) only the stiffness is checked
    fleet_data_from_table(table.drop(columns="mu"), require_outcome=False)


def test_one_row_per_type_rejected():
    table = pd.DataFrame(
        {
            "tyre_id": ["a", "b", "c"],
            "tyre_type": list(TYRE_TYPES),
            "c_xr": [30.0, 40.0, 55.0],
            "mu": [0.45, 0.4, 0.2],
        }
    )
    with pytest.raises(BadInputError, match="at least 2 rows per tyre type"):
        fleet_data_from_table(table)


def test_other_bad_inputs_rejected():
    with pytest.raises(BadInputError, match="surface"):
        fleet_data_from_table(_table(surface="gravel"))
    with pytest.raises(BadInputError, match="c_xr_sd"):
        fleet_data_from_table(_table(c_xr_sd=0.0))
    table = _table()
    table.loc[1, "mu"] = np.nan
    with pytest.raises(BadInputError, match="mu: expected finite"):
        fleet_data_from_table(table)
    dup = pd.concat([_table(), _table().iloc[:1]])
    with pytest.raises(BadInputError, match="one row per tyre_id and surface"):
        fleet_data_from_table(dup)
    with pytest.raises(BadInputError, match="method"):
        fit_fleet(_table(), method="mcmc")
    # one word for randomness in every fitter: the old keyword names the new one
    with pytest.raises(TypeError, match="'key' is now 'seed'"):
        fit_fleet(_table(), key=0)
    # the package's own check, or the test run's runtime type checker before it
    with pytest.raises(TypeError, match="seed: expected an int|parameter 'seed'"):
        fit_fleet(_table(), seed=0.5)


def test_table_without_sd_or_surface_uses_defaults():
    data = fleet_data_from_table(_table().drop(columns=["c_xr_sd", "surface"]))
    assert np.all(data.c_xr_sd == load_tyre_type_priors().default_c_xr_sd)
    assert np.all(data.row_surface == SURFACES.index("snow"))


# --- fit: recovery, structure, prediction -------------------------------------------------------


def test_nuts_fit_converges_and_has_arviz_groups(fit120):
    table, _, fit = fit120
    diag = fit.diagnostics
    assert fit.kind == "fleet" and diag.method == "nuts"
    assert diag.converged and not diag.reasons, diag.as_dict()
    assert diag.r_hat_max <= 1.02 and diag.ess_bulk_min >= 200 and diag.ess_tail_min >= 200
    # The simulated fleet follows the model: its predictive check passes.
    assert diag.adequate and diag.adequacy_reasons == ()
    for group in ("posterior", "observed_data", "log_likelihood", "posterior_predictive"):
        assert group in fit.data.children
    assert fit.data["log_likelihood"]["mu"].shape[-1] == len(table)
    assert fit.attr("fitted_surfaces") == ["snow"]
    assert fit.provenance.method == "nuts" and fit.provenance.model == "hierarchical"


def test_saved_fleet_fit_loads_back_and_predicts_the_same(fit120, tmp_path):
    _, _, fit = fit120
    path = fit.save(tmp_path / "fleet.nc")
    loaded = load_fit(path, kind="fleet")
    assert loaded.kind == "fleet"
    np.testing.assert_equal(loaded.diagnostics.as_dict(), fit.diagnostics.as_dict())
    assert loaded.provenance == fit.provenance
    np.testing.assert_array_equal(loaded.draws("a"), fit.draws("a"))
    np.testing.assert_array_equal(
        predict_friction(loaded, 30.0, 1.0, None, "snow", seed=4),
        predict_friction(fit, 30.0, 1.0, None, "snow", seed=4),
    )
    assert fit_summary(loaded) == fit_summary(fit)
    with pytest.raises(BadInputError, match="expected a tyre fit, got a fleet fit"):
        load_fit(path, kind="tyre")


def test_too_short_a_run_is_reported_not_converged():
    table, _ = simulate_fleet(5, 26)
    fit = fit_fleet(table, seed=0, num_warmup=10, num_samples=10, num_chains=2)
    assert not fit.converged
    assert any("ESS" in r for r in fit.diagnostics.reasons), fit.diagnostics.reasons


def test_recovers_type_level_snow_parameters(fit120):
    _, truth, fit = fit120
    post = fit.posterior
    for t in TYRE_TYPES:
        a_true, b_true, s_true = TYPE_FRICTION["snow"][t]
        a = post["a"].sel(surface="snow", tyre_type=t).values.ravel()
        s = post["sigma"].sel(surface="snow", tyre_type=t).values.ravel()
        # Intercepts: within 3 posterior sd of the truth and 0.03 absolute (36-48 sets per type,
        # residual sd ~0.03 -> posterior sd ~0.005).
        assert abs(a.mean() - a_true) < max(3 * a.std(), 0.01), (t, a.mean(), a_true)
        assert abs(a.mean() - a_true) < 0.03
        # Residual scale: within a factor of 1.5 of the truth.
        assert s_true / 1.5 < s.mean() < s_true * 1.5, (t, s.mean(), s_true)
        # Slopes are weakly identified per type; the truth must lie in the central 98 %.
        b = post["b"].sel(surface="snow", tyre_type=t).values.ravel()
        lo, hi = np.quantile(b, [0.01, 0.99])
        assert lo < b_true < hi, (t, lo, hi, b_true)
    # Stiffness population medians (30 / 40 / 55) within 5 %.
    med = np.exp(post["stiff_loc"].mean(("chain", "draw")).values)
    assert np.allclose(med, [30.0, 40.0, 55.0], rtol=0.05), med
    # Latent C_xr: closer to the truth than the noisy measurement on average (shrinkage).
    c_post = post["c_xr_true"].mean(("chain", "draw")).values
    c_obs = fit.data["constant_data"]["c_xr_obs"].values
    order = np.argsort(np.array(post["tyre"].values, dtype=str))
    c_true = truth["c_xr_true"][order]
    assert np.mean((c_post - c_true) ** 2) < np.mean((c_obs - c_true) ** 2)


def test_predict_friction_known_and_unknown_type(fit120):
    _, _, fit = fit120
    winter = predict_friction(fit, 30.0, 1.0, "winter", "snow", seed=1)
    summer = predict_friction(fit, 55.0, 1.0, "summer", "snow", seed=1)
    assert abs(winter.mean() - 0.45) < 0.03 and abs(summer.mean() - 0.18) < 0.03
    # Predictive sd: residual scatter (~0.03) plus parameter uncertainty, so 0.025-0.06.
    assert 0.025 < winter.std() < 0.06
    # Unknown type with a summer-like stiffness: the mixture is dominated by summer.
    w = type_probabilities(fit, 56.0, 1.0)
    assert np.allclose(w.sum(axis=1), 1.0)
    assert w[:, 2].mean() > 0.9
    unknown = predict_friction(fit, 56.0, 1.0, None, "snow", seed=1)
    assert abs(unknown.mean() - summer.mean()) < 0.03
    # Between the types the mixture is wider than either type's own prediction.
    mid = predict_friction(fit, 36.0, 2.0, None, "snow", seed=1)
    assert mid.std() > winter.std()


def test_unfitted_surface_predicts_from_prior(fit120):
    _, _, fit = fit120
    p = load_tyre_type_priors()
    dry = predict_friction(fit, 55.0, 1.0, "summer", "dry", seed=2)
    # Prior mean 1.15 (braking data), prior sd ~0.1 on a plus scatter: wide.
    assert abs(dry.mean() - p.mu[SURFACES.index("dry"), 2]) < 0.05
    assert dry.std() > 0.08


def test_predictive_logpdf_prefers_truth_like_data(fit120):
    _, _, fit = fit120
    new, _ = simulate_fleet(99, 30)
    lp = predictive_logpdf(fit, new)
    assert lp.shape == (30,) and np.all(np.isfinite(lp))
    shifted = new.assign(mu=new["mu"] + 0.15)
    assert predictive_logpdf(fit, shifted).sum() < lp.sum() - 50


def test_bad_prediction_inputs(fit120):
    _, _, fit = fit120
    with pytest.raises(BadInputError, match="surface"):
        predict_friction(fit, 30.0, 1.0, "winter", "sand")
    with pytest.raises(BadInputError, match="tyre type"):
        predict_friction(fit, 30.0, 1.0, "racing", "snow")
    with pytest.raises(BadInputError, match="c_xr"):
        predict_friction(fit, -1.0, 1.0, "winter", "snow")


@pytest.mark.slow
def test_svi_recovers_type_level_parameters_on_large_multi_surface_fleet():
    table, _ = simulate_fleet(21, 3000, surface=("snow", "ice"))
    fit = fit_fleet(table, method="svi", seed=0, svi_steps=3000)
    assert fit.converged and fit.diagnostics.optimiser_result == "successful"
    for s in ("snow", "ice"):
        for t in TYRE_TYPES:
            a_true, b_true, _ = TYPE_FRICTION[s][t]
            a = fit.posterior["a"].sel(surface=s, tyre_type=t).values.mean()
            b = fit.posterior["b"].sel(surface=s, tyre_type=t).values.mean()
            assert abs(a - a_true) < 0.01, (s, t, a, a_true)
            assert abs(b - b_true) < 0.04, (s, t, b, b_true)
