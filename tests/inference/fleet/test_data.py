"""The fleet table's lateral columns (tyrebayes.inference.fleet.data): c_y beside C_x."""

import numpy as np
import pytest

from tyrebayes._errors import BadInputError
from tyrebayes.inference.fleet import fleet_data_from_table
from tyrebayes.simulate.fleet import simulate_fleet

RATIO = {"winter": (0.5, 0.1), "all_season": (0.4, 0.1), "summer": (0.3, 0.1)}


def _table(**kw):
    table, truth = simulate_fleet(4, 12, lateral_ratio=RATIO, lateral_share=0.5, **kw)
    return table, truth


def test_fleet_table_with_c_y_carries_it_per_set_and_leaves_the_rest_empty():
    table, truth = _table(surface=("snow", "ice"))
    data = fleet_data_from_table(table)
    # one c_y per set (both surfaces' rows agree), NaN for the sets driven only straight
    order = np.argsort([f"T{i:05d}" for i in range(12)])
    has = truth["has_lateral"][order]
    assert np.array_equal(np.isfinite(data.c_y), has) and has.sum() == 6
    assert np.array_equal(data.lateral_tyres, np.flatnonzero(has))
    first = table.drop_duplicates("tyre_id").set_index("tyre_id")
    np.testing.assert_allclose(data.c_y[has], first["c_y"].to_numpy()[order][has])
    # c_y_sd is the relative error times c_y: within the simulated 0.06-0.15
    rel = data.c_y_sd[has] / data.c_y[has]
    assert np.all((rel >= 0.06) & (rel <= 0.15))
    # the measurement is close to the truth k_i C_true_i
    c_y_true = truth["c_y_true"][order][has]
    assert np.all(np.abs(np.log(data.c_y[has] / c_y_true)) < 4 * rel)


def test_table_without_c_y_has_no_lateral_sets():
    table, _ = simulate_fleet(4, 12)
    data = fleet_data_from_table(table)
    assert data.lateral_tyres.size == 0 and np.all(np.isnan(data.c_y))


def test_bad_lateral_columns_are_rejected_in_one_line():
    table, _ = _table()
    with pytest.raises(BadInputError, match="expected a c_y_sd column beside c_y"):
        fleet_data_from_table(table.drop(columns="c_y_sd"))
    row = int(np.flatnonzero(np.isfinite(table["c_y"]))[0])
    bad = table.copy()
    bad.loc[row, "c_y"] = 1500.0  # N/rad per N, not normalised
    with pytest.raises(BadInputError, match=rf"c_y: expected .*\[1, 100\].*1500 in row {row}"):
        fleet_data_from_table(bad)
    bad = table.copy()
    bad.loc[row, "c_y_sd"] = 0.0
    with pytest.raises(BadInputError, match=f"c_y_sd: expected a positive.*row {row}"):
        fleet_data_from_table(bad)


def test_rows_of_one_set_must_agree_on_c_y():
    table, _ = _table(surface=("snow", "ice"))
    tyre = table.loc[np.isfinite(table["c_y"]), "tyre_id"].iloc[0]
    rows = table.index[table["tyre_id"] == tyre]
    table.loc[rows[1], "c_y"] = table.loc[rows[0], "c_y"] * 1.1
    with pytest.raises(BadInputError, match=f"tyre_id {tyre}: expected one c_y"):
        fleet_data_from_table(table)


def test_lateral_only_rows_keep_the_set_and_leave_the_outcome_rows():
    table, _ = _table()
    lateral = np.flatnonzero(np.isfinite(table["c_y"]))
    table.loc[lateral[:2], "mu"] = np.nan  # cornered, never braked at the limit
    with pytest.raises(BadInputError, match="mu: expected finite numbers"):
        fleet_data_from_table(table)
    data = fleet_data_from_table(table, lateral_only_rows=True)
    assert data.n_tyres == 12 and len(data.y) == 10 and np.all(np.isfinite(data.y))
    assert data.lateral_tyres.size == 6
    # a row without c_y still needs its outcome
    straight = int(np.flatnonzero(~np.isfinite(table["c_y"]))[0])
    table.loc[straight, "mu"] = np.nan
    with pytest.raises(BadInputError, match="mu: expected finite numbers"):
        fleet_data_from_table(table, lateral_only_rows=True)
    # and some row must have an outcome
    only, _ = _table()
    only = only[np.isfinite(only["c_y"])].assign(mu=np.nan)
    with pytest.raises(BadInputError, match="at least one row with a value"):
        fleet_data_from_table(only, lateral_only_rows=True)
