"""Tests of the fleet commands: fit-fleet, predict, warn (tyrebayes._commands.fleet)."""

import json

import pytest

from tyrebayes.cli import main
from tyrebayes.inference.result import load_fit
from tyrebayes.simulate.fleet import simulate_fleet


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """fit-fleet on a simulated 26-set snow fleet (default NUTS settings), JSON output captured."""
    d = tmp_path_factory.mktemp("fleet")
    table, _ = simulate_fleet(4, 26)
    table.to_csv(d / "fleet.csv", index=False)
    out = d / "fit.nc"
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(
            [
                "fit-fleet",
                str(d / "fleet.csv"),
                "--outcome",
                "mu",
                "--out",
                str(out),
                "--json",
            ]
        )
    return d, out, code, json.loads(buf.getvalue())


def _run(capsys, argv):
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_fit_fleet_writes_netcdf_atomically_and_reports(fitted):
    d, out, code, payload = fitted
    assert code == 0 and out.is_file()
    # No temporary file left beside the output.
    assert sorted(p.name for p in d.iterdir()) == ["fit.nc", "fleet.csv"]
    assert payload["out"] == str(out)
    assert payload["n_sets"] == 26 and payload["fitted_surfaces"] == ["snow"]
    assert payload["converged"] is True and payload["diagnostics"]["converged"] is True
    assert payload["adequate"] is True and payload["adequacy_reasons"] == []
    assert payload["diagnostics"]["method"] == "nuts" and payload["diagnostics"]["n_chains"] == 2
    winter = payload["parameters"]["snow"]["winter"]["a"]
    assert set(winter) == {"mean", "sd", "hdi_90"}
    assert abs(winter["mean"] - 0.45) < 0.05


def test_fit_fleet_exits_3_on_a_fit_that_did_not_converge(tmp_path, capsys):
    table, _ = simulate_fleet(4, 26)
    table.to_csv(tmp_path / "fleet.csv", index=False)
    out = tmp_path / "short.nc"
    argv = ["fit-fleet", str(tmp_path / "fleet.csv"), "--out", str(out), "--json"]
    code, stdout, stderr = _run(capsys, [*argv, "--samples", "10", "--warmup", "10"])
    payload = json.loads(stdout)
    assert code == 3 and payload["converged"] is False
    assert "did not converge" in stderr and "ESS" in stderr
    # Still written, and marked as such in the file.
    assert load_fit(out, kind="fleet").converged is False
    code, stdout, _ = _run(capsys, ["fit-fleet", str(tmp_path / "fleet.csv"), "--samples", "10"])
    assert code == 3 and "NOT CONVERGED" in stdout and "model adequate" in stdout


def test_predict_json(fitted, capsys):
    _, out, _, _ = fitted
    code, stdout, _ = _run(
        capsys,
        ["predict", str(out), "--c-xr", "30", "--c-xr-sd", "1.5", "--type", "winter", "--json"],
    )
    assert code == 0
    payload = json.loads(stdout)
    assert set(payload["mu"]) == {"mean", "sd", "hdi_90"}
    assert set(payload["p_below"]) == {"0.3", "0.45", "0.6"}
    p = payload["p_below"]
    assert p["0.3"] <= p["0.45"] <= p["0.6"]
    assert abs(payload["mu"]["mean"] - 0.45) < 0.05
    assert payload["prior_only"] is False
    code, stdout, _ = _run(
        capsys,
        ["predict", str(out), "--c-xr", "30", "--type", "winter", "--surface", "dry", "--json"],
    )
    assert code == 0 and json.loads(stdout)["prior_only"] is True


def test_predict_flags_extrapolation_outside_the_fleets_stiffness(fitted, capsys):
    _, out, _, _ = fitted

    def predict(c_xr: str, tyre_type: str = "winter") -> dict:
        argv = ["predict", str(out), "--c-xr", c_xr, "--type", tyre_type, "--json"]
        code, stdout, _ = _run(capsys, argv)
        assert code == 0
        return json.loads(stdout)

    inside = predict("28")
    assert inside["extrapolation"] is False and inside["extrapolation_note"] is None
    lo, hi = inside["c_xr_range"]  # the simulated fleet's winter sets
    assert lo < 28 < hi < 45
    far = predict("500")
    assert far["extrapolation"] is True and far["c_xr_range"] == [lo, hi]
    assert "winter sets on snow" in far["extrapolation_note"]
    # 45 is a summer/all-season stiffness: inside the fleet, outside its winter sets.
    assert predict("45")["extrapolation"] is True
    assert predict("45", "unknown")["extrapolation"] is False
    code, stdout, _ = _run(capsys, ["predict", str(out), "--c-xr", "500", "--type", "winter"])
    assert code == 0 and "note: C_xr 500 is outside the range" in stdout
    code, stdout, _ = _run(
        capsys, ["warn", str(out), "--c-xr", "500", "--type", "winter", "--json"]
    )
    assert code == 0 and json.loads(stdout)["extrapolation"] is True


@pytest.mark.parametrize(
    "args,verdict",
    [
        (["--c-xr", "29", "--c-xr-sd", "1", "--type", "winter"], "ok"),
        (["--c-xr", "55", "--c-xr-sd", "1", "--type", "summer"], "warn"),
        # A vague set: its 90 % interval reaches 0.1 below μ_min (the tolerance is 0.08); at
        # ±12 it reached 0.078-0.083 below, and the verdict was the sampler's chance.
        (["--c-xr", "40", "--c-xr-sd", "20", "--type", "unknown"], "insufficient_evidence"),
    ],
)
def test_warn_verdicts(fitted, capsys, args, verdict):
    _, out, _, _ = fitted
    code, stdout, _ = _run(capsys, ["warn", str(out), *args, "--json"])
    assert code == 0
    payload = json.loads(stdout)
    assert payload["verdict"] == verdict
    assert payload["threshold"] == pytest.approx(0.1)
    assert 0.0 <= payload["probability"] <= 1.0


def test_warn_human_output_and_costs(fitted, capsys):
    _, out, _, _ = fitted
    code, stdout, _ = _run(
        capsys,
        [
            "warn",
            str(out),
            "--c-xr",
            "55",
            "--type",
            "summer",
            "--cost-miss",
            "1",
            "--cost-false-alarm",
            "1",
        ],
    )
    assert code == 0 and stdout.startswith("warn: ") and "0.500" in stdout


def _bad_table(tmp_path, mutate):
    table, _ = simulate_fleet(4, 12)
    table = mutate(table)
    path = tmp_path / "bad.csv"
    table.to_csv(path, index=False)
    return path


@pytest.mark.parametrize(
    "mutate,message",
    [
        (lambda t: t.assign(tyre_type=t.tyre_type.replace("summer", "racing")), "tyre_type"),
        (lambda t: t.drop(columns="c_xr"), "c_xr"),
        (lambda t: t.assign(c_xr=-t.c_xr), "positive stiffness"),
        (lambda t: t.groupby("tyre_type").head(1), "at least 2 rows"),
        (lambda t: t.drop(columns="mu"), "--outcome"),
        (lambda t: t.assign(c_xr=t.c_xr.where(t.index != 3, 1e300)), "got 1e+300 in row 3"),
        (lambda t: t.assign(mu=100 * t.mu), "(percent? divide by 100)"),
        (lambda t: t.assign(mu=-t.mu), "mu: expected a friction coefficient in (0, 2), got -"),
    ],
)
def test_bad_tables_exit_2_with_one_line(tmp_path, capsys, mutate, message):
    path = _bad_table(tmp_path, mutate)
    code, stdout, stderr = _run(
        capsys,
        ["fit-fleet", str(path), "--outcome", "mu", "--json", "--out", str(tmp_path / "x.nc")],
    )
    assert code == 2 and stdout == ""
    assert stderr.count("\n") == 1 and message in stderr
    assert not (tmp_path / "x.nc").exists()


def test_bad_fit_file_and_values_exit_2(fitted, tmp_path, capsys):
    _, out, _, _ = fitted
    junk = tmp_path / "junk.nc"
    junk.write_text("not netcdf")
    code, _, err = _run(capsys, ["predict", str(junk), "--c-xr", "30", "--type", "winter"])
    assert code == 2 and "fleet fit" in err
    code, _, err = _run(
        capsys, ["predict", str(tmp_path / "missing.nc"), "--c-xr", "30", "--type", "winter"]
    )
    assert code == 2 and "file not found" in err
    code, _, err = _run(capsys, ["warn", str(out), "--c-xr", "-5", "--type", "winter"])
    assert code == 2 and "--c-xr" in err
    code, _, err = _run(
        capsys, ["warn", str(out), "--c-xr", "30", "--type", "winter", "--surface", "ice"]
    )
    assert code == 2 and "--mu-min" in err


def test_table_reads_parquet(tmp_path, capsys):
    table, _ = simulate_fleet(4, 12)
    table["tyre_type"] = "gravel"
    table.to_parquet(tmp_path / "t.parquet")
    code, _, err = _run(capsys, ["fit-fleet", str(tmp_path / "t.parquet"), "--outcome", "mu"])
    assert code == 2 and "tyre_type" in err
