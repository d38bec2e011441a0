"""`tyrebayes criticize` and `tyrebayes criticize-stream` on files: --json and bad input."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest

from tyrebayes._resources import data_dir
from tyrebayes.cli import main
from tyrebayes.simulate.fleet import THESIS_AGED_TYRE_EFFECT, simulate_fleet


@pytest.fixture
def aged_fleet_csv(tmp_path):
    table, _ = simulate_fleet(7, 26, effects=("age",), n_decoys=3)
    path = tmp_path / "fleet.csv"
    table.to_csv(path, index=False)
    return path


def test_criticize_json_contract_and_finding(aged_fleet_csv, capsys):
    assert main(["criticize", str(aged_fleet_csv), "--outcome", "mu", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"baseline", "candidates", "found"}
    assert set(out["baseline"]) == {"elpd", "se"}
    assert out["found"] == ["age_years"]
    first = out["candidates"][0]
    assert set(first) == {"covariate", "elpd_gain", "se", "effect"}
    assert set(first["effect"]) == {"mean", "sd", "hdi_90"}
    assert first["covariate"] == "age_years"
    assert first["elpd_gain"] > 2 * first["se"]
    lo, hi = first["effect"]["hdi_90"]
    assert lo <= -THESIS_AGED_TYRE_EFFECT <= hi
    names = [c["covariate"] for c in out["candidates"]]
    assert sorted(names) == sorted(
        [
            "age_years",
            "tread_depth_mm",
            "pressure_bar",
            "load_index",
            "decoy_1",
            "decoy_2",
            "decoy_3",
        ]
    )


def test_criticize_human_output(aged_fleet_csv, capsys):
    assert main(["criticize", str(aged_fleet_csv), "--outcome", "mu"]) == 0
    text = capsys.readouterr().out
    assert "found (Holm p <= alpha and ELPD gain > 2 SE): age_years" in text
    assert "posterior predictive checks" in text


def test_criticize_26_rows_within_30_s_as_a_command(aged_fleet_csv):
    """The issue's timing target, measured end to end (interpreter start and imports included)."""
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "tyrebayes.cli", "criticize", str(aged_fleet_csv)]
        + ["--outcome", "mu", "--json"],
        capture_output=True,
        text=True,
        check=False,
    )
    elapsed = time.perf_counter() - start
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["found"] == ["age_years"]
    assert elapsed < 30.0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["criticize", "no/such/file.csv", "--outcome", "mu"], "file not found"),
        (["criticize", "{fleet}", "--outcome", "grip"], "expected a column 'grip'"),
        (["criticize", "{fleet}", "--outcome", "mu", "--alpha", "2"], "--alpha"),
        (["criticize", "{fleet}", "--outcome", "mu", "--surface", "ice"], "surface"),
        (["criticize", "{fleet}", "--outcome", "mu", "--se-factor", "-1"], "--se-factor"),
        (["criticize-stream", "{fleet}", "--vehicle", "suv_rav4"], "missing required columns"),
        (["criticize-stream", "{stream}", "--vehicle", "no_such_car"], "vehicle"),
    ],
)
def test_bad_input_exit_2_one_line(args, message, aged_fleet_csv, capsys):
    stream = data_dir() / "comma2k19_rav4_segment.csv"
    argv = [a.format(fleet=aged_fleet_csv, stream=stream) for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert message in err


def test_criticize_stream_real_log_json(capsys):
    path = data_dir() / "comma2k19_rav4_segment.csv"
    assert main(["criticize-stream", str(path), "--vehicle", "suv_rav4", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"baseline", "candidates", "found"}
    assert all(set(c) == {"covariate", "elpd_gain", "se", "effect"} for c in out["candidates"])
    assert set(out["found"]) <= {c["covariate"] for c in out["candidates"]}
