"""Predictions of the fleet's lateral ratio (tyrebayes.inference.fleet.predict)."""

import json

import arviz_base as azb
import numpy as np
import pytest

from tyrebayes._domain import TYRE_TYPES
from tyrebayes._errors import BadInputError
from tyrebayes.inference.diagnostics import diagnose
from tyrebayes.inference.fleet import (
    fit_fleet,
    has_lateral_ratio,
    lateral_ratio_draws,
    lateral_ratio_summary,
    lateral_sets_per_type,
)
from tyrebayes.inference.result import Fit, provenance
from tyrebayes.simulate.fleet import simulate_fleet

DRAWS = 2000


def stub_fleet_fit(loc=(0.5, 0.4, 0.3), loc_sd=0.02, spread=0.1, counts=(20, 15, 0)) -> Fit:
    """A fleet fit whose ratio posterior is known: exp(k_loc) about ``loc``, k_scale = spread."""
    rng = np.random.default_rng(0)
    k_loc = np.log(loc)[None, None, :] + loc_sd * rng.standard_normal((1, DRAWS, 3))
    data = azb.from_dict(
        {"posterior": {"k_loc": k_loc, "k_scale": np.full((1, DRAWS, 3), spread)}},
        coords={"tyre_type": list(TYRE_TYPES)},
        dims={"k_loc": ["tyre_type"], "k_scale": ["tyre_type"]},
    )
    data.attrs["lateral_sets_per_type"] = json.dumps(dict(zip(TYRE_TYPES, counts, strict=True)))
    return Fit(
        data=data,
        diagnostics=diagnose(data, method="svi", optimiser_result="successful"),
        kind="fleet",
        provenance=provenance("svi", "hierarchical", ("stub",)),
    )


def test_ratio_draws_hold_the_median_uncertainty_and_the_set_scatter():
    fit = stub_fleet_fit()
    k = lateral_ratio_draws(fit, "winter", 4000, seed=1)
    assert k.shape == (4000,)
    assert abs(np.median(k) / 0.5 - 1) < 0.02
    # log-sd: sqrt(0.02^2 + 0.1^2) = 0.102, not the median's 0.02 alone
    assert 0.09 < np.std(np.log(k)) < 0.115
    assert np.allclose(np.median(lateral_ratio_draws(fit, "summer", seed=1)), 0.3, rtol=0.02)
    # same seed, same draws
    np.testing.assert_array_equal(k, lateral_ratio_draws(fit, "winter", 4000, seed=1))


def test_ratio_summary_says_which_types_were_learnt_from_data():
    fit = stub_fleet_fit()
    s = lateral_ratio_summary(fit)
    assert s["winter"]["from"] == "data" and s["winter"]["n_sets"] == 20
    assert s["summer"]["from"] == "prior" and s["summer"]["n_sets"] == 0
    assert abs(s["all_season"]["median_ratio"]["mean"] - 0.4) < 0.01
    assert lateral_sets_per_type(fit) == {"winter": 20, "all_season": 15, "summer": 0}


def test_fit_without_ratio_and_bad_inputs_are_refused():
    fit = stub_fleet_fit()
    with pytest.raises(BadInputError, match="tyre type: expected one of"):
        lateral_ratio_draws(fit, "racing")
    with pytest.raises(BadInputError, match="n: expected at least 1"):
        lateral_ratio_draws(fit, "winter", 0)
    plain = azb.from_dict({"posterior": {"a": np.zeros((1, 10))}})
    no_ratio = Fit(
        data=plain,
        diagnostics=diagnose(plain, method="svi", optimiser_result="successful"),
        kind="fleet",
        provenance=provenance("svi", "hierarchical", ("stub",)),
    )
    assert not has_lateral_ratio(no_ratio) and lateral_ratio_summary(no_ratio) is None
    with pytest.raises(BadInputError, match="expected the lateral ratio"):
        lateral_ratio_draws(no_ratio, "winter")


@pytest.mark.slow
def test_nuts_fit_recovers_each_types_ratio():
    """A 90-set fleet, 70 % with c_y: every type's median ratio inside its central 98 % interval
    (one fleet: the 90 % coverage over fleets is the benchmark's) and within 8 %."""
    ratio = {"winter": (0.52, 0.1), "all_season": (0.38, 0.1), "summer": (0.30, 0.1)}
    table, _ = simulate_fleet(
        7, 90, type_shares={"winter": 0.4, "all_season": 0.3, "summer": 0.3},
        lateral_ratio=ratio, lateral_share=0.7,
    )  # fmt: skip
    fit = fit_fleet(table, seed=0)
    assert fit.converged, fit.diagnostics.reasons
    s = lateral_ratio_summary(fit)
    for i, t in enumerate(TYRE_TYPES):
        lo, hi = np.quantile(np.exp(fit.draws("k_loc")[:, i]), [0.01, 0.99])
        assert lo <= ratio[t][0] <= hi, (t, lo, hi)
        assert abs(s[t]["median_ratio"]["mean"] / ratio[t][0] - 1) < 0.08
        assert s[t]["from"] == "data"
