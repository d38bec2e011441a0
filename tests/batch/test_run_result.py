"""A fleet run's result: counts from the records, the outcome, and ``to_dict`` as the JSON that
``summary.json`` and ``fleet-run --json`` give."""

from __future__ import annotations

import dataclasses
import json

import pytest

from tyrebayes._io import to_jsonable
from tyrebayes.batch import FleetRunResult, RunSettings
from tyrebayes.batch.run_result import StageStats, run_outcome

DRIVES = [
    {"status": "done", "drive_id": "d1", "path": "d1.parquet", "duration_s": 1800.0,
     "seconds": 3.0, "cpu_seconds": 2.5, "peak_rss_mb": 700.0, "programs_dropped": False},
    {"status": "done", "drive_id": "d2", "skipped": True, "duration_s": 3600.0},
    {"status": "failed", "drive_id": "d3", "path": "d3.parquet", "reason": "corrupt file",
     "seconds": 0.5, "cpu_seconds": 0.25, "peak_rss_mb": 650.0},
]  # fmt: skip
SETS = [
    {"status": "done", "tyre_set_id": "s1", "seconds": 12.0, "cpu_seconds": 11.0,
     "peak_rss_mb": 1200.0, "programs_dropped": True},
    {"status": "failed", "tyre_set_id": "s2", "reason": "no drive done", "skipped": True},
]  # fmt: skip
FLEET = {"status": "failed", "reason": "no set observed mu_max", "rows": 1, "seconds": 0.75}


def _result(**settings) -> FleetRunResult:
    return FleetRunResult.from_records(
        DRIVES,
        SETS,
        FLEET,
        ["drive_summaries", "tyre_sets"],
        wall_seconds=30.0,
        workers=2,
        client_peak_rss_mb=310.0,
        settings=RunSettings(**settings),
    )


def test_to_dict_is_the_summary_json():
    # The dict the run summary had before it was typed: same keys, order and values.
    expected = {
        "drives": {"items": 3, "done": 1, "skipped": 1, "failed": 1, "failed_now": 1,
                   "seconds": 3.5, "cpu_seconds": 2.75, "peak_rss_mb_max": 700.0,
                   "programs_dropped": 0},
        "tyre_sets": {"items": 2, "done": 1, "skipped": 1, "failed": 1, "failed_now": 0,
                      "seconds": 12.0, "cpu_seconds": 11.0, "peak_rss_mb_max": 1200.0,
                      "programs_dropped": 1},
        "fleet": {"status": "failed", "skipped": False, "reason": "no set observed mu_max",
                  "rows": 1, "seconds": 0.75},
        "failures": [
            {"item": "drive", "id": "d3", "reason": "corrupt file"},
            {"item": "tyre_set", "id": "s2", "reason": "no drive done"},
            {"item": "fleet", "id": "fleet", "reason": "no set observed mu_max"},
        ],
        "drive_hours": 0.5,
        "wall_seconds": 30.0,
        "workers": 2,
        "client_peak_rss_mb": 310.0,
        "settings": {"method": "nuts", "model": "linear", "seed": 3, "window_s": 0.5},
        "outputs": {"drive_summaries": "drive_summaries.parquet",
                    "tyre_sets": "tyre_sets.parquet", "failures": "failures.csv",
                    "fleet": "fleet/"},
        "written": ["drive_summaries", "tyre_sets", "failures"],
        "outcome": "failures",
    }  # fmt: skip
    got = _result(method="nuts", model="linear", seed=3, window_s=0.5).to_dict()
    assert got == expected
    assert list(got) == list(expected)
    assert json.dumps(to_jsonable(got)) == json.dumps(expected)
    # JSON types: the counts are ints (sums of booleans), not floats or NumPy scalars.
    assert all(type(got["drives"][k]) is int for k in ("items", "done", "programs_dropped"))


def test_typed_fields_and_a_fresh_dict_each_time():
    result = _result()
    assert result.drives == StageStats.from_records(DRIVES)
    assert result.fleet.status == "failed" and result.failures[0].item_id == "d3"
    result.to_dict()["outputs"]["fleet"] = "changed"
    result.to_dict()["written"].append("changed")
    assert result.to_dict()["outputs"]["fleet"] == "fleet/"
    assert result.to_dict()["written"] == ["drive_summaries", "tyre_sets", "failures"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.outcome = "ok"


def test_a_run_with_nothing_yet():
    result = FleetRunResult.from_records(
        [], [], {}, [], wall_seconds=0.0, workers=0, client_peak_rss_mb=0.0,
        settings=RunSettings(),
    )  # fmt: skip
    summary = result.to_dict()
    assert summary["drives"]["peak_rss_mb_max"] == 0.0 and summary["failures"] == []
    assert summary["fleet"] == {"status": None, "skipped": False, "reason": "", "rows": 0,
                                "seconds": 0.0}  # fmt: skip
    assert summary["outcome"] == "nothing_usable" and summary["written"] == ["failures"]


def test_outcome_of_a_run():
    done, failed = {"status": "done"}, {"status": "failed"}
    assert run_outcome([done], [done], done) == "ok"
    assert run_outcome([done, failed], [done], done) == "failures"
    assert run_outcome([done], [done, failed], done) == "failures"
    assert run_outcome([done], [done], failed) == "failures"  # no fleet model: not all done
    assert run_outcome([failed, failed], [failed], failed) == "nothing_usable"
    assert run_outcome([done], [failed], failed) == "nothing_usable"
