"""One drive's windows as a typed table: construction, checks, dict round trip, pickling."""

import pickle

import numpy as np
import pytest

from tyrebayes import BadInputError, WindowTable, windowed_observations
from tyrebayes.inference.tyre.window_table import OPTIONAL_COLUMNS, REQUIRED_COLUMNS


def _windows(n: int = 6) -> WindowTable:
    return WindowTable(
        slip=np.linspace(0.001, 0.003, n),
        rho=np.linspace(0.05, 0.2, n),
        slip_sd=np.full(n, 2e-4),
        rho_sd=np.full(n, 0.01),
        temperature_c=np.full(n, 20.0),
        time_s=0.125 + 0.25 * np.arange(n),
        at_limit=np.arange(n) == n - 1,
        drive=(np.arange(n) >= n // 2).astype(np.int64),
    )


def test_columns_take_their_dtype_and_the_table_its_length():
    table = _windows()
    assert len(table) == table.n_windows == 6
    assert table.at_limit.dtype == bool and table.drive.dtype == np.int64
    assert table.slip.dtype == np.float64 and table.neighbour_slip is None
    assert repr(table).startswith("WindowTable(n_windows=6, columns=['slip'")


def test_bad_lengths_and_missing_columns_are_one_line_errors():
    columns = _windows().to_dict()
    with pytest.raises(BadInputError, match=r"^window table: rho_sd expected 6 windows, got 5$"):
        WindowTable.from_dict({**columns, "rho_sd": np.zeros(5)})
    with pytest.raises(BadInputError, match=r"expected 6 windows, got 4$"):
        WindowTable.from_dict({**columns, "wheel_speed": np.zeros(4)})
    with pytest.raises(BadInputError, match="one dimension, got shape"):
        WindowTable.from_dict({**columns, "slip": np.zeros((6, 2))})
    missing = {k: v for k, v in columns.items() if k != "time_s"}
    with pytest.raises(BadInputError, match=r"missing \['time_s'\]$"):
        WindowTable.from_dict(missing)
    with pytest.raises(BadInputError, match="mask expected shape"):
        _windows().select(np.ones(3, bool))
    with pytest.raises(BadInputError, match=r"^window table: rho expected 6 windows, got 2$"):
        _windows().replace(rho=np.zeros(2))
    with pytest.raises(BadInputError, match=r"got \['wheel_speed'\]$"):
        _windows().replace(wheel_speed=np.zeros(6))


def test_dict_round_trip_is_exact():
    t = np.arange(0.0, 30.0, 0.01)
    rho = 0.1 + 0.05 * np.sin(t)
    slip = rho / 30.0 + np.random.default_rng(0).normal(0.0, 1e-3, t.size)
    windows = windowed_observations(
        t, slip, rho, 1e-3, 0.01, also={"load_change": -0.5 * rho, "pedal": rho}
    )
    columns = windows.to_dict()
    # What windowed_observations gave as a dict: the five channels, their times and
    # neighbours, and the ``also`` channels (a column's name fills that column).
    assert set(columns) == {*REQUIRED_COLUMNS, "neighbour_slip", "load_change", "pedal"}
    assert set(windows.extra) == {"pedal"}
    again = WindowTable.from_dict(columns)
    assert again.to_dict().keys() == columns.keys()
    for name, values in columns.items():
        np.testing.assert_array_equal(again.to_dict()[name], values, err_msg=name)


def test_select_replace_and_concatenate_keep_every_column():
    table = _windows()
    later = table.select(table.time_s > 0.5)
    assert len(later) == 4 and later.drive.tolist() == [0, 1, 1, 1]
    np.testing.assert_array_equal(table.select(slice(None, None, 2)).slip, table.slip[::2])
    moved = table.replace(slip=table.slip + 1.0, drive=None)
    assert moved.drive is None and table.drive is not None
    both = WindowTable.concatenate([table, moved.replace(drive=table.drive)])
    assert len(both) == 12 and both.at_limit.sum() == 2
    with pytest.raises(BadInputError, match="expected columns"):
        WindowTable.concatenate([table, moved])
    assert set(OPTIONAL_COLUMNS) >= {"at_limit", "drive"}


def test_a_table_pickles():
    table = _windows().replace(extra={"pedal": np.ones(6)})
    again = pickle.loads(pickle.dumps(table))
    assert isinstance(again, WindowTable) and again.to_dict().keys() == table.to_dict().keys()
    for name, values in table.to_dict().items():
        np.testing.assert_array_equal(again.to_dict()[name], values, err_msg=name)
