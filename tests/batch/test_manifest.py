"""Manifest reading: resolved rows, and one-line errors for every malformed manifest."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from tyrebayes import BadInputError
from tyrebayes.batch.manifest import manifest_from_table, read_manifest


def _write(tmp_path, rows, name="m.csv"):
    path = tmp_path / name
    table = pd.DataFrame(rows)
    if name.endswith(".parquet"):
        table.to_parquet(path, index=False)
    else:
        table.to_csv(path, index=False)
    return path


def test_rows_are_resolved_against_the_manifest_folder(tmp_path):
    rows = [
        {"path": "logs/a.parquet", "vehicle": "compact_fwd", "tyre_set_id": "s1",
         "tyre_type": "winter", "surface": "snow", "ambient_c": "-3.5"},
        {"path": "logs/b.parquet", "vehicle": "cars/my.toml", "tyre_set_id": "s1",
         "tyre_type": "", "surface": "", "ambient_c": ""},
    ]  # fmt: skip
    items = read_manifest(_write(tmp_path, rows))
    assert [i.path for i in items] == [
        str((tmp_path / "logs/a.parquet").resolve()),
        str((tmp_path / "logs/b.parquet").resolve()),
    ]
    assert items[0].vehicle == "compact_fwd"  # a preset name stays a name
    assert items[1].vehicle == str((tmp_path / "cars/my.toml").resolve())
    assert (items[0].surface, items[1].surface) == ("snow", "dry")
    assert items[0].ambient_c == -3.5 and math.isnan(items[1].ambient_c)
    assert items[0].drive_id != items[1].drive_id


def test_parquet_manifest(tmp_path):
    rows = [{"path": "a.parquet", "vehicle": "compact_fwd", "tyre_set_id": 7}]
    items = read_manifest(_write(tmp_path, rows, "m.parquet"))
    assert items[0].tyre_set_id == "7"


def test_glob_needs_a_vehicle_and_gives_one_set(tmp_path):
    for name in ("x1.parquet", "x2.parquet"):
        (tmp_path / name).write_bytes(b"")
    pattern = str(tmp_path / "x*.parquet")
    with pytest.raises(BadInputError, match="expected --vehicle"):
        read_manifest(pattern)
    items = read_manifest(pattern, vehicle="compact_fwd")
    assert [i.tyre_set_id for i in items] == ["compact_fwd", "compact_fwd"]
    with pytest.raises(BadInputError, match="expected matching logs"):
        read_manifest(str(tmp_path / "none*.csv"), vehicle="compact_fwd")


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ([{"path": "a", "vehicle": "v"}], r"missing \['tyre_set_id'\]"),
        ([{"path": "", "vehicle": "v", "tyre_set_id": "s"}], "row 1: expected a value in 'path'"),
        (
            [{"path": "a", "vehicle": "v", "tyre_set_id": "s", "tyre_type": "racing"}],
            "row 1: tyre_type expected one of",
        ),
        (
            [{"path": "a", "vehicle": "v", "tyre_set_id": "s", "surface": "gravel"}],
            "row 1: surface expected one of",
        ),
        (
            [{"path": "a", "vehicle": "v", "tyre_set_id": "s", "ambient_c": "warm"}],
            "row 1: ambient_c expected a temperature",
        ),
        (
            [{"path": "a", "vehicle": "v", "tyre_set_id": "s", "ambient_c": "300"}],
            "ambient_c expected -60..60",
        ),
        (
            [
                {"path": "a", "vehicle": "v", "tyre_set_id": "s"},
                {"path": "a", "vehicle": "w", "tyre_set_id": "t"},
            ],
            "row 2: expected each log once",
        ),
    ],
)
def test_bad_rows_are_one_line_errors(tmp_path, rows, message):
    with pytest.raises(BadInputError, match=message) as err:
        read_manifest(_write(tmp_path, rows))
    assert "\n" not in str(err.value)


def test_bad_manifest_files(tmp_path):
    with pytest.raises(BadInputError, match="got no file") as err:
        read_manifest(tmp_path / "missing.csv")
    assert "\n" not in str(err.value)
    bad = tmp_path / "bad.parquet"
    bad.write_bytes(b"not parquet")
    with pytest.raises(BadInputError, match="expected CSV or Parquet") as err:
        read_manifest(bad)
    assert "\n" not in str(err.value)
    with pytest.raises(BadInputError, match="empty table"):
        manifest_from_table(pd.DataFrame(columns=["path", "vehicle", "tyre_set_id"]))
    with pytest.raises(BadInputError, match="only with a glob"):
        read_manifest(_write(tmp_path, [{"path": "a", "vehicle": "v", "tyre_set_id": "s"}]),
                      vehicle="compact_fwd")  # fmt: skip


# --- contradictions between rows, refused before any work (issue 57) ---------------------------


def test_one_tyre_set_with_two_tyre_types_is_refused_with_both_rows(tmp_path):
    rows = [
        {"path": "a.parquet", "vehicle": "v", "tyre_set_id": "s1", "tyre_type": "winter"},
        {"path": "b.parquet", "vehicle": "v", "tyre_set_id": "s2", "tyre_type": "summer"},
        {"path": "c.parquet", "vehicle": "v", "tyre_set_id": "s1", "tyre_type": ""},
        {"path": "d.parquet", "vehicle": "v", "tyre_set_id": "s1", "tyre_type": "summer"},
    ]
    with pytest.raises(BadInputError) as err:
        read_manifest(_write(tmp_path, rows))
    message = str(err.value)
    assert message.startswith("manifest rows 1 and 4: expected one tyre_type per tyre set")
    assert "'s1' as 'winter' (row 1) and 'summer' (row 4)" in message and "\n" not in message
    # A row without a type takes its set's: no contradiction.
    rows[3]["tyre_type"] = "winter"
    items = read_manifest(_write(tmp_path, rows))
    assert [i.tyre_set_id for i in items] == ["s1", "s2", "s1", "s1"]


def test_one_log_under_two_sets_names_both_rows_and_sets(tmp_path):
    rows = [
        {"path": "logs/a.parquet", "vehicle": "v", "tyre_set_id": "s1"},
        {"path": "b.parquet", "vehicle": "v", "tyre_set_id": "s1"},
        {"path": str(tmp_path / "logs" / "a.parquet"), "vehicle": "v", "tyre_set_id": "s2"},
    ]
    with pytest.raises(BadInputError) as err:
        read_manifest(_write(tmp_path, rows))
    message = str(err.value)
    assert message.startswith("manifest row 3: expected each log once, got ")
    assert "again (row 1) under tyre sets 's1' (row 1) and 's2'" in message
    assert "\n" not in message


def test_one_log_under_two_names_through_a_link_is_one_log(tmp_path):
    (tmp_path / "a.parquet").write_bytes(b"")
    (tmp_path / "link.parquet").symlink_to(tmp_path / "a.parquet")
    rows = [
        {"path": "a.parquet", "vehicle": "v", "tyre_set_id": "s1"},
        {"path": "link.parquet", "vehicle": "v", "tyre_set_id": "s2"},
    ]
    with pytest.raises(BadInputError, match=r"row 2: expected each log once.*\(row 1\)"):
        read_manifest(_write(tmp_path, rows))


def test_fleet_run_refuses_a_contradiction_before_any_work(tmp_path, capsys):
    from tyrebayes.cli import main

    rows = [
        {"path": "a.parquet", "vehicle": "compact_fwd", "tyre_set_id": "s", "tyre_type": "winter"},
        {"path": "b.parquet", "vehicle": "compact_fwd", "tyre_set_id": "s", "tyre_type": "summer"},
    ]
    out = tmp_path / "out"
    assert main(["fleet-run", str(_write(tmp_path, rows)), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "manifest rows 1 and 2" in err
    assert not out.exists()  # no cluster started, nothing written
