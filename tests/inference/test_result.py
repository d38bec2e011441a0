"""The one result type: diagnostics under one policy, adequacy, saving and loading a fit."""

import json

import arviz_base as azb
import numpy as np
import pytest

from tyrebayes._errors import BadInputError
from tyrebayes.inference.result import (
    FIT_KINDS,
    POLICY,
    ConvergencePolicy,
    Diagnostics,
    Fit,
    diagnose,
    load_fit,
    posterior_predictive_adequacy,
    provenance,
)


def _tree(chains=4, draws=500, shift=0.0, diverging=0, seed=0):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(chains, draws))
    x[0] += shift  # one chain elsewhere: the chains disagree
    div = np.zeros((chains, draws), bool)
    div.flat[:diverging] = True
    y = rng.normal(size=20)
    return azb.from_dict(
        {
            "posterior": {"x": x, "b": rng.normal(size=(chains, draws, 3))},
            "sample_stats": {"diverging": div},
            "observed_data": {"y": y},
            "posterior_predictive": {"y": rng.normal(size=(chains, draws, 20))},
        }
    )


def test_well_mixed_chains_converge():
    d = diagnose(_tree(), method="nuts")
    assert d.converged and d.reasons == () and d.reason == ""
    assert d.r_hat_max < 1.01 and d.ess_bulk_min > 1000 and d.ess_tail_min > 1000
    assert d.n_chains == 4 and d.n_draws == 500 and d.adequate


def test_each_check_of_the_policy_can_fail():
    assert "R-hat" in diagnose(_tree(shift=1.0), method="nuts").reason
    assert "ESS" in diagnose(_tree(chains=2, draws=10), method="nuts").reason
    # 3 of 2000 transitions diverged: above one per thousand (2 are allowed).
    assert "divergent" in diagnose(_tree(diverging=3), method="nuts").reason
    assert diagnose(_tree(diverging=2), method="nuts").converged
    strict = ConvergencePolicy(divergence_max_fraction=0.0)
    assert not diagnose(_tree(diverging=1), method="nuts", policy=strict).converged


def test_approximate_methods_are_judged_by_their_optimiser():
    ok = diagnose(_tree(chains=1), method="laplace", optimiser_result="successful")
    assert ok.converged and np.isnan(ok.r_hat_max) and ok.ess_bulk_min == 500
    bad = diagnose(_tree(chains=1), method="svi", optimiser_result="max_steps_reached")
    assert not bad.converged and bad.reasons == ("optimiser: max_steps_reached",)
    extra = diagnose(
        _tree(chains=1), method="fast", optimiser_result="successful", problems=["Hessian"]
    )
    assert extra.reasons == ("Hessian",)


def test_bad_arguments_name_expected_and_got():
    with pytest.raises(ValueError, match="expected one of .* got 'mcmc'"):
        diagnose(_tree(), method="mcmc")
    with pytest.raises(ValueError, match=r"unknown \['z'\]"):
        diagnose(_tree(), method="nuts", var_names=["z"])
    with pytest.raises(ValueError, match="r_hat_max: expected >= 1"):
        ConvergencePolicy(r_hat_max=0.9)


def test_adequacy_and_its_predictive_check():
    tree = _tree()
    assert posterior_predictive_adequacy(tree, "y") == ()
    tree["observed_data"]["y"] = tree["observed_data"]["y"] + 5.0  # data the model cannot make
    reasons = posterior_predictive_adequacy(tree, "y")
    assert reasons and "mean" in reasons[0]
    d = diagnose(tree, method="nuts").with_adequacy(reasons)
    assert d.converged and not d.adequate and d.adequacy_reasons == reasons
    assert d.with_adequacy(["noted"], adequate=True).adequate


def test_diagnostics_json_round_trip():
    d = diagnose(_tree(chains=1), method="laplace", optimiser_result="successful")
    back = Diagnostics.from_dict(json.loads(json.dumps({**d.as_dict(), "r_hat_max": None})))
    np.testing.assert_equal(back.as_dict(), d.as_dict())
    assert POLICY.r_hat_max == 1.02


def test_saved_fit_loads_back_and_checks_its_kind(tmp_path):
    tree = _tree()
    tree.attrs["note"] = json.dumps({"a": 1})
    fit = Fit(
        data=tree,
        diagnostics=diagnose(tree, method="nuts"),
        kind="fleet",
        provenance=provenance("nuts", "hierarchical", ["t.csv"], seed=3),
    )
    path = fit.save(tmp_path / "sub" / "fit.nc")
    assert sorted(p.name for p in path.parent.iterdir()) == ["fit.nc"]  # no temporary left
    loaded = load_fit(path)
    assert loaded.kind == "fleet" and loaded.provenance == fit.provenance
    assert loaded.provenance.as_dict()["settings"] == {"seed": 3}
    assert loaded.attr("note") == {"a": 1}
    np.testing.assert_equal(loaded.diagnostics.as_dict(), fit.diagnostics.as_dict())
    np.testing.assert_array_equal(loaded.draws("b"), fit.draws("b"))
    with pytest.raises(BadInputError, match="expected a wear fit, got a fleet fit"):
        load_fit(path, kind="wear")
    with pytest.raises(KeyError, match="expected a posterior variable, got 'nope'"):
        loaded.draws("nope")


def test_files_that_are_not_fits_are_bad_input(tmp_path):
    junk = tmp_path / "junk.nc"
    junk.write_text("not netcdf")
    with pytest.raises(BadInputError, match="expected a saved fit"):
        load_fit(junk)
    plain = tmp_path / "plain.nc"
    _tree().to_netcdf(plain, engine="netcdf4")
    with pytest.raises(BadInputError, match="without one"):
        load_fit(plain)
    with pytest.raises(BadInputError, match="file not found"):
        load_fit(tmp_path / "missing.nc")
    with pytest.raises(ValueError, match="kind: expected one of"):
        Fit(
            data=_tree(),
            diagnostics=diagnose(_tree(), method="nuts"),
            kind="x",
            provenance=provenance("nuts", "m"),
        )


#: Per kind, the method its fitter records and the kind-specific attributes it keeps as JSON in
#: ``data.attrs`` (shapes as the fitters write them; the fitters' own tests round-trip their real
#: fits: tests/inference/tyre/test_model.py, test_fleet.py, test_wear.py, vmax/test_censored.py,
#: tests/test_cli_fit_wear.py, tests/inference/lateral/test_fit.py).
_KIND_CASES = {
    "tyre": ("laplace", {"surfaces": ["dry"], "model_kind": "magic"}),
    "fleet": ("svi", {"tyre_types": ["summer", "winter"], "x_scale": 1.5}),
    "wear": ("nuts", {"sets": ["a", "b"], "c_xr_lognormal": [3.5, 0.2]}),
    "vmax": ("nuts", {"course": "iso3888_2", "draws": 200}),
    "wear_history": ("nuts", {"readings": 7, "changes": [[120.0, "swap"]]}),
    "lateral": ("laplace", {"axles": ["front", "rear"], "relaxation": None}),
}


def test_the_round_trip_cases_cover_every_fit_kind():
    assert set(_KIND_CASES) == set(FIT_KINDS)


@pytest.mark.parametrize("kind", FIT_KINDS)
def test_every_fit_kind_round_trips_through_save_and_load_fit(kind, tmp_path):
    method, attrs = _KIND_CASES[kind]
    tree = _tree(chains=1 if method != "nuts" else 4, draws=50, seed=len(kind))
    for name, value in attrs.items():
        tree.attrs[name] = json.dumps(value)
    fit = Fit(
        data=tree,
        diagnostics=diagnose(tree, method=method, optimiser_result="successful"),
        kind=kind,
        provenance=provenance(method, f"{kind} model", [f"{kind}.csv"], seed=7),
    )
    loaded = load_fit(fit.save(tmp_path / f"{kind}.nc"), kind=kind)

    assert loaded.kind == kind
    assert loaded.provenance == fit.provenance
    np.testing.assert_equal(loaded.diagnostics.as_dict(), fit.diagnostics.as_dict())
    assert {name: loaded.attr(name) for name in attrs} == attrs
    assert sorted(loaded.data.children) == sorted(fit.data.children)
    for group in fit.data.children:
        saved, back = fit.data[group].to_dataset(), loaded.data[group].to_dataset()
        assert sorted(back.data_vars) == sorted(saved.data_vars), group
        for name in saved.data_vars:
            assert back[name].dtype == saved[name].dtype, (group, name)
            assert back[name].dims == saved[name].dims, (group, name)
            np.testing.assert_array_equal(back[name].values, saved[name].values)
    # Saved once more from what was loaded, the file reads back the same again.
    again = load_fit(loaded.save(tmp_path / f"{kind}-again.nc"), kind=kind)
    assert again.provenance == fit.provenance and again.data.attrs == loaded.data.attrs
