"""The cornering simulator's planned manoeuvre: kept in the truth, checked, named ``manoeuvre``."""

import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.simulate.cornering import simulate_cornering

VEHICLE = load_vehicle("compact_fwd")


def test_the_manoeuvre_is_recorded_in_the_truth():
    frame, truth = simulate_cornering(VEHICLE, manoeuvre="straight", duration_s=5.0, seed=1)
    assert truth.manoeuvre == "straight" and len(frame) == 500


def test_an_unknown_manoeuvre_is_a_value_error():
    with pytest.raises(ValueError, match="manoeuvre: expected 'mixed', 'steady' or 'straight'"):
        simulate_cornering(VEHICLE, manoeuvre="slalom", duration_s=5.0)


def test_the_old_keyword_is_refused_naming_manoeuvre():
    with pytest.raises(TypeError, match="keyword 'kind' is now 'manoeuvre'"):
        simulate_cornering(VEHICLE, kind="mixed", duration_s=5.0)
