"""V_max per draw and its summary: draws beyond the search range are censored, not dropped."""

import numpy as np

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.vmax import (
    SEARCH_RANGE_KMH,
    VmaxInputs,
    VmaxPrediction,
    range_counts,
    vmax_draws,
)


def test_a_draw_below_the_search_range_is_its_lower_end():
    v = np.asarray(vmax_draws(load_vehicle("compact_fwd"), np.full(2, 18.0), np.array([0.1, 1.0])))
    assert v[0] == SEARCH_RANGE_KMH[0]
    assert SEARCH_RANGE_KMH[0] < v[1] < SEARCH_RANGE_KMH[1]
    assert range_counts(v) == {"below_range": 1, "above_range": 0, "undefined": 0}


def test_a_posterior_mostly_below_the_range_is_summarised_as_such():
    # 70 % of the draws below 29 km/h: the interval starts at the range's end and stays low,
    # where the bracketed draws alone (40-56 km/h) would describe another tyre.
    low = SEARCH_RANGE_KMH[0]
    rng = np.random.default_rng(0)
    draws = np.concatenate([np.full(700, low), rng.uniform(40.0, 56.0, 300)])
    c = np.full(draws.size, 15.0)
    inputs = VmaxInputs(c, c, np.full(draws.size, 0.3), "measured", "surface_prior", "snow")
    out = VmaxPrediction(draws, inputs, "compact_fwd").to_dict()
    assert out["v_max_kmh"]["hdi_90"][0] == low
    assert out["v_max_kmh"]["mean"] < 40.0
    assert (out["below_range"], out["above_range"], out["not_bracketed"]) == (700, 0, 700)
    assert out["search_range_kmh"] == list(SEARCH_RANGE_KMH)
