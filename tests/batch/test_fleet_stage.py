"""The fleet table from tyre-set rows: only observed μ_max of converged sets of known type
whose drives measured C_x."""

from __future__ import annotations

import numpy as np
import pandas as pd

from tyrebayes.batch.fleet_stage import fleet_table, run_fleet_stage
from tyrebayes.batch.settings import RunSettings
from tyrebayes.batch.tyre_set_stage import pad_size


def _row(tyre_id, tyre_type="winter", converged=True, measured=True, **observed):
    row = {"tyre_id": tyre_id, "tyre_type": tyre_type, "c_xr": 30.0, "c_xr_sd": 1.0,
           "converged": converged, "c_x_measured": measured}  # fmt: skip
    for s in ("snow", "ice", "wet", "dry"):
        row[f"mu_{s}"] = observed.get(s, 0.5)
        row[f"mu_{s}_observed"] = s in observed
    return row


def test_fleet_table_keeps_only_observations():
    sets = pd.DataFrame(
        [
            _row("a", snow=0.31, dry=0.9),
            _row("b", snow=0.35),
            _row("c"),  # nothing observed: its μ are priors
            _row("d", tyre_type="", snow=0.3),  # type unknown
            _row("e", converged=False, snow=0.3),
            _row("f", measured=False, snow=0.3),  # its drives did not measure C_x
            _row("g", snow=0.9, dry=0.95) | {"mu_snow_prior_sds": 4.3, "mu_dry_prior_sds": -0.3},
            # 2.7 sds from snow's median, but 80 times likelier on a dry road.
            _row("h", snow=0.9) | {"mu_snow_prior_sds": 2.7, "mu_snow_label_log_bf": 4.4},
            _row("i", snow=0.5) | {"mu_snow_prior_sds": 1.0, "mu_snow_label_log_bf": -1.0},
        ]
    )
    table = fleet_table(sets)
    assert list(zip(table["tyre_id"], table["surface"], table["mu"], strict=True)) == [
        ("a", "snow", 0.31),
        ("a", "dry", 0.9),
        ("b", "snow", 0.35),
        ("g", "dry", 0.95),  # its "snow" is a dry road's μ: the label is in doubt
        ("i", "snow", 0.5),
    ]


def test_fleet_stage_without_observations_is_a_recorded_failure(tmp_path):
    sets = pd.DataFrame([_row("a"), _row("b")])
    record = run_fleet_stage(str(tmp_path), sets, RunSettings())
    assert record["status"] == "failed" and "observed" in record["reason"]
    assert (tmp_path / "fleet" / "fleet_table.csv").is_file()
    again = run_fleet_stage(str(tmp_path), sets, RunSettings())
    assert again["skipped"]


def test_pad_sizes_are_few():
    lengths = np.unique(np.geomspace(10, 200_000, 500).astype(int))
    sizes = {pad_size(int(n)) for n in lengths}
    # Four per octave from 256 (2^8), and none wastes a quarter of its work or more.
    grid = {(4 + j) * 2 ** (k - 2) for k in range(8, 18) for j in range(4)}
    assert sizes == {s for s in grid if s <= pad_size(200_000)}
    assert all(n <= pad_size(int(n)) < 1.25 * max(int(n), 205) for n in lengths)
    assert all(pad_size(n) >= n for n in (1, 255, 256, 257, 65_536, 65_537))


def test_fleet_stage_fits_and_predicts_per_set(tmp_path):
    from tyrebayes.inference.result import load_fit

    sets = pd.DataFrame(
        [
            _row(f"w{i}", "winter", snow=mu) | {"c_xr": c}
            for i, (c, mu) in enumerate([(28.0, 0.33), (30.0, 0.31), (26.0, 0.35)])
        ]
        + [
            _row(f"s{i}", "summer", snow=mu) | {"c_xr": c}
            for i, (c, mu) in enumerate([(50.0, 0.22), (55.0, 0.20), (47.0, 0.24)])
        ]
        + [_row("x", "summer")]  # nothing observed: predicted, not fitted
    )
    record = run_fleet_stage(str(tmp_path), sets, RunSettings())
    assert record["status"] == "done", record["reason"]
    assert record["rows"] == 6
    assert load_fit(tmp_path / "fleet" / "fleet.nc", kind="fleet").data is not None
    pred = pd.read_parquet(tmp_path / "fleet" / "predictions.parquet")
    assert list(pred["tyre_id"]) == list(sets["tyre_id"])
    assert set(pred["verdict"]) <= {"ok", "warn", "insufficient_evidence"}
    by_id = pred.set_index("tyre_id")
    assert by_id.loc["w0", "p_below_mu_min"] < by_id.loc["s0", "p_below_mu_min"]
    assert (pred["mu_q05"] < pred["mu_mean"]).all() and (pred["mu_mean"] < pred["mu_q95"]).all()


def test_a_table_written_before_c_x_measured_existed_keeps_its_sets():
    old = _row("a", snow=0.31)
    del old["c_x_measured"]
    assert list(fleet_table(pd.DataFrame([old]))["tyre_id"]) == ["a"]


def test_fleet_table_carries_c_y_beside_c_x_and_keeps_sets_that_only_cornered():
    lat = {"c_y": 14.0, "c_y_sd": 1.4}
    sets = pd.DataFrame(
        [
            _row("a", snow=0.31, dry=0.9) | lat,  # braked and cornered: c_y on both rows
            _row("b", snow=0.35) | {"c_y": np.nan, "c_y_sd": np.nan},  # driven straight
            _row("c") | lat,  # cornered, never braked at the limit: a row without μ
            _row("d") | {"c_y": np.nan, "c_y_sd": np.nan},  # neither: not in the table
            _row("e", converged=False) | lat,
            _row("f", measured=False) | lat,  # C_x not measured: no ratio to learn
            _row("g", tyre_type="") | lat,  # type unknown
        ]
    )
    table = fleet_table(sets)
    assert list(table.columns) == ["tyre_id", "tyre_type", "c_xr", "c_xr_sd", "c_y", "c_y_sd",
                                   "mu", "surface"]  # fmt: skip
    got = [(r.tyre_id, r.surface, r.c_y, r.mu) for r in table.itertuples()]
    assert got[:3] == [
        ("a", "snow", 14.0, 0.31),
        ("a", "dry", 14.0, 0.9),
        ("b", "snow", got[2][2], 0.35),
    ]
    assert np.isnan(got[2][2])
    assert got[3][:3] == ("c", "snow", 14.0) and np.isnan(got[3][3])
    assert len(got) == 4
    # the fleet model reads it: c's set stays (stiffness and c_y), its row leaves the outcome's
    from tyrebayes.inference.fleet import fleet_data_from_table

    data = fleet_data_from_table(table[table["surface"] == "snow"], lateral_only_rows=True)
    assert data.tyre_ids == ("a", "b", "c") and len(data.y) == 2
    assert data.lateral_tyres.tolist() == [0, 2]


def test_predictions_say_where_each_sets_c_y_comes_from():
    from tests.inference.fleet.test_predict import stub_fleet_fit
    from tyrebayes.batch.fleet_stage import _lateral_prediction

    fit = stub_fleet_fit(loc=(0.5, 0.4, 0.3), loc_sd=0.01, spread=0.05)
    own = _lateral_prediction(fit, _row("a") | {"c_y": 14.0, "c_y_sd": 1.4}, "winter", 0)
    assert own["c_y_source"] == "measured" and own["c_y_mean"] == 14.0
    assert own["c_y_q05"] < 14.0 < own["c_y_q95"]
    straight = _lateral_prediction(fit, _row("b"), "winter", 0)  # C_xr 30 ± 1, no c_y
    assert straight["c_y_source"] == "fleet_type_ratio"
    assert abs(straight["c_y_mean"] / (0.5 * 30.0) - 1) < 0.03
    assert straight["c_y_q05"] < 15.0 < straight["c_y_q95"]
    unknown = _lateral_prediction(fit, _row("c"), None, 0)
    assert unknown["c_y_source"] == "" and np.isnan(unknown["c_y_mean"])
