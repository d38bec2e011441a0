"""A wear evidence table's lateral work put on another cornering stiffness (W_y ∝ 1 / c_y)."""

import numpy as np
import pandas as pd
import pytest

from tyrebayes.streams.cornering_stiffness import TYPE_PRIOR_CORNERING, CorneringStiffness
from tyrebayes.streams.wear_evidence_table import with_cornering


def _table() -> pd.DataFrame:
    prior = TYPE_PRIOR_CORNERING
    return pd.DataFrame(
        {
            "work_y_front_j": [100.0, 200.0],
            "work_y_rear_j": [60.0, 80.0],
            "cornering_stiffness_front_per_rad": [prior.front_per_rad, 20.0],
            "cornering_stiffness_rear_per_rad": [prior.rear_per_rad, 20.0],
            "cornering_stiffness_log_sd": [prior.log_sd, 0.2],
        }
    )


def test_the_rows_asked_for_scale_by_old_over_new_c_y_and_the_rest_stay():
    new = CorneringStiffness(2 * TYPE_PRIOR_CORNERING.front_per_rad, 33.0, 0.1, "drive_lateral")
    out = with_cornering(_table(), new, rows=np.array([True, False]))
    assert out["work_y_front_j"].tolist() == pytest.approx([50.0, 200.0])
    assert out["work_y_rear_j"].tolist() == pytest.approx(
        [60.0 * TYPE_PRIOR_CORNERING.rear_per_rad / 33.0, 80.0]
    )
    assert out["cornering_stiffness_log_sd"].tolist() == [0.1, 0.2]
    # a fleet summary states no source: the untouched rows say what their numbers are
    assert out["cornering_stiffness_source"].tolist() == ["drive_lateral", "given"]
    assert _table()["work_y_front_j"].tolist() == [100.0, 200.0]  # the input is not changed


def test_back_to_the_first_stiffness_is_the_first_table():
    there = with_cornering(_table(), CorneringStiffness(25.0, 30.0, 0.1, "x"))
    back = with_cornering(there, CorneringStiffness(TYPE_PRIOR_CORNERING.front_per_rad, 20.0, 0.1))
    assert back["work_y_front_j"].iloc[0] == pytest.approx(100.0)
    assert back["work_y_rear_j"].iloc[1] == pytest.approx(80.0)


def test_a_table_without_the_lateral_work_is_refused():
    with pytest.raises(ValueError, match="missing \\['work_y_front_j'"):
        with_cornering(_table().drop(columns="work_y_front_j"), TYPE_PRIOR_CORNERING)
