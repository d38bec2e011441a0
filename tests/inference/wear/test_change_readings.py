"""Tread readings decide a change's type where the radius ratio's test was unsure."""

import numpy as np
import pandas as pd
import pytest

from tests.inference.test_wear_history import GAMMA, synthetic_table
from tyrebayes import BadInputError
from tyrebayes.inference.wear.change_readings import classify_changes_by_readings
from tyrebayes.inference.wear.history import drive_history, reading_exposure, tread_readings
from tyrebayes.inference.wear.history_fit import NEW_DEPTH_MM, NEW_DEPTH_SD_MM
from tyrebayes.physics.wear import TreadGeometry

AREA = float(TreadGeometry().wear_area_mm2)


def _readings(history, noise_mm=0.05, seed=0):
    """Both axles read at drives 10, 20 and the end, with the wear of ``history``'s layout."""
    rng = np.random.default_rng(seed)
    odometers = [history.odometer_km[10], history.odometer_km[20], history.end_km]
    probe = tread_readings(
        pd.DataFrame(
            {
                "odometer_km": np.repeat(odometers, 2),
                "axle": ["front", "rear"] * 3,
                "depth_mm": np.full(6, 7.0),
            }
        )
    )
    exposure, _ = reading_exposure(history, probe)
    lost = GAMMA * np.einsum("mja,ja->m", exposure, (history.work_j + history.work_y_j) / 2 / AREA)
    depth = NEW_DEPTH_MM - lost + noise_mm * rng.standard_normal(lost.size)
    return tread_readings(
        pd.DataFrame(
            {
                "odometer_km": np.repeat(odometers, 2),
                "axle": ["front", "rear"] * 3,
                "depth_mm": depth,
            }
        )
    )


def _classify(history, readings):
    return classify_changes_by_readings(
        history,
        readings,
        new_depth_mm=NEW_DEPTH_MM,
        new_depth_sd_mm=NEW_DEPTH_SD_MM,
        wear_area_mm2=AREA,
    )


@pytest.mark.parametrize("truth", ["rotation", "replacement"])
def test_readings_turn_an_unsure_change_to_the_type_that_wore_them(truth):
    """A change at drive 14 that the ratio test put the other way at 0.6: readings taken with
    the true layout give it back its type, with a probability above the test's."""
    h = drive_history(synthetic_table()[0])
    assert h.changes.index.tolist() == [14]
    true = h.with_change_types((truth,), [1.0])
    wrong = "replacement" if truth == "rotation" else "rotation"
    unsure = h.with_change_types((wrong,), [0.6])
    out = _classify(unsure, _readings(true))
    assert out.changes.change_type == (truth,)
    assert out.changes.probability[0] > 0.6
    np.testing.assert_array_equal(out.pair, true.pair)


def test_readings_that_agree_keep_the_type_and_no_readings_change_nothing():
    h = drive_history(synthetic_table()[0])
    unsure = h.with_change_types(("rotation",), [0.6])
    out = _classify(unsure, _readings(h.with_change_types(("rotation",), [1.0])))
    assert out.changes.change_type == ("rotation",)
    assert out.changes.probability[0] > 0.6
    empty = tread_readings(pd.DataFrame({"odometer_km": [], "axle": [], "depth_mm": []}))
    assert _classify(h, empty) is h


def test_readings_no_layout_admits_are_bad_input():
    """Depths that grow on one pair before the change: no change type explains them."""
    h = drive_history(synthetic_table()[0])
    readings = tread_readings(
        pd.DataFrame(
            {
                "odometer_km": [h.odometer_km[3], h.odometer_km[10]],
                "axle": ["front", "front"],
                "depth_mm": [7.0, 7.8],
            }
        )
    )
    with pytest.raises(BadInputError, match="do not increase"):
        _classify(h, readings)
