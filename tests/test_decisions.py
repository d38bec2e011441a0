"""Tests of the winter-suitability rule (tyrebayes.decisions)."""

import numpy as np
import pandas as pd
import pytest

from tyrebayes._errors import BadInputError
from tyrebayes._resources import data_dir
from tyrebayes.decisions import (
    DEFAULT_MU_MIN_SNOW,
    check_mu_min,
    cost_threshold,
    derive_mu_min_snow,
    stiffness_extrapolation,
    winter_verdict,
)


def _normal(mean, sd, n=4000, seed=0):
    return np.random.default_rng(seed).normal(mean, sd, n)


def test_default_mu_min_derived_from_braking_data():
    # Midpoint of the lowest winter snow deceleration (ADAC 2018: 0.338) and the summer bound
    # (What Car?: > twice 17.7 m from 40.2 km/h -> < 0.180).
    assert derive_mu_min_snow() == pytest.approx((0.33786 + 0.17953) / 2, abs=1e-4)
    assert round(derive_mu_min_snow(), 2) == DEFAULT_MU_MIN_SNOW


def test_default_passes_measured_winter_and_fails_summer():
    raw = pd.read_csv(data_dir() / "braking_by_tyre_type.csv")
    snow = raw[(raw.surface == "snow") & raw.distance_m.notna()]
    decel = (snow.speed_from_kmh / 3.6) ** 2 / (2 * 9.81 * snow.distance_m)
    # Every measured winter and all-season set on snow decelerates above mu_min (lower bounds on
    # its mu_max), by at least 0.07.
    assert (decel - DEFAULT_MU_MIN_SNOW > 0.07).all()
    # The summer sets' deceleration bound (0.180) lies below mu_min by more than 0.07.
    assert DEFAULT_MU_MIN_SNOW - 0.1795 > 0.07


def test_cost_threshold():
    assert cost_threshold(1.0, 9.0) == pytest.approx(0.1)
    assert cost_threshold(1.0, 1.0) == pytest.approx(0.5)
    with pytest.raises(BadInputError, match="costs"):
        cost_threshold(0.0, 1.0)


def test_clear_cases():
    good = winter_verdict(_normal(0.45, 0.035))
    assert good.verdict == "ok" and good.probability < 0.001
    summer = winter_verdict(_normal(0.18, 0.035))
    assert summer.verdict == "warn" and summer.probability > 0.98
    # the warn command's JSON keys, in their order (issue 58: unchanged by the typed result)
    assert list(good.to_dict()) == [
        "verdict",
        "probability",
        "threshold",
        "mu_min",
        "mu",
        "interval_90",
        "costs",
        "straddle_tol",
        "n_draws",
        "reason",
    ]


def test_borderline_cases_follow_the_cost_threshold():
    # Well-known set just above mu_min: P(mu < 0.26) ~ 0.05 < 0.1 -> ok.
    near_ok = winter_verdict(_normal(0.31, 0.03))
    assert near_ok.verdict == "ok" and 0.02 < near_ok.probability < 0.08
    # Slightly closer: P ~ 0.16 > 0.1 -> warn (a miss costs 9x a false alarm).
    near_warn = winter_verdict(_normal(0.29, 0.03))
    assert near_warn.verdict == "warn" and 0.1 < near_warn.probability < 0.25
    # Same draws with equal costs: threshold 0.5 -> ok.
    assert winter_verdict(_normal(0.29, 0.03), cost_miss=1.0).verdict == "ok"
    # Exactly at mu_min with a tight prediction is still decidable (warn), not "insufficient".
    at = winter_verdict(_normal(0.26, 0.03))
    assert at.verdict == "warn"


def test_insufficient_evidence_when_interval_straddles_widely():
    vague = winter_verdict(_normal(0.30, 0.12))
    assert vague.verdict == "insufficient_evidence"
    assert vague.interval_90[0] < 0.26 - 0.08 < 0.26 + 0.08 < vague.interval_90[1]
    # A wide prediction that lies wholly on one side is still decided.
    assert winter_verdict(_normal(0.60, 0.12)).verdict == "ok"
    # Bimodal (unknown type, winter or summer): insufficient, not a warning.
    mix = np.concatenate([_normal(0.45, 0.03, 2000), _normal(0.18, 0.03, 2000, seed=1)])
    assert winter_verdict(mix).verdict == "insufficient_evidence"


def test_bad_draws():
    with pytest.raises(BadInputError, match="at least 10"):
        winter_verdict(np.array([0.3, np.nan]))


@pytest.mark.parametrize(
    ("mu_min", "needle"),
    [(-5.0, "got -5$"), (0.0, "got 0$"), (26.0, r"percent\? use 0.26"), (float("nan"), "nan")],
)
def test_mu_min_outside_any_tyres_friction_is_rejected(mu_min, needle):
    with pytest.raises(BadInputError, match=needle):
        winter_verdict(_normal(0.45, 0.03), mu_min=mu_min)
    assert check_mu_min(1.2) == 1.2


def test_stiffness_extrapolation():
    fleet = [22.0, 30.0, 33.5]
    assert stiffness_extrapolation(30.0, fleet) == {
        "extrapolation": False,
        "c_xr_range": [22.0, 33.5],
        "extrapolation_note": None,
    }
    above, below = stiffness_extrapolation(67.0, fleet), stiffness_extrapolation(11.0, fleet)
    assert above["extrapolation"] and "2x its maximum" in above["extrapolation_note"]
    assert below["extrapolation"] and "2x below its minimum" in below["extrapolation_note"]
    none = stiffness_extrapolation(30.0, [np.nan], "the fleet's summer sets")
    assert none["extrapolation"] and none["c_xr_range"] is None
