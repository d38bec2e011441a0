"""``tyrebayes fit-tyre``: bad inputs exit 2 with one line; a full run on a simulated drive."""

import json

import pandas as pd
import pytest

from tyrebayes.cli import main


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


def test_missing_file(tmp_path, capsys):
    code = main(["fit-tyre", str(tmp_path / "nope.csv"), "--vehicle", "compact_fwd"])
    assert code == 2
    assert "file not found" in _one_line_error(capsys)


def test_wrong_columns(tmp_path, capsys):
    path = tmp_path / "bad.csv"
    pd.DataFrame({"time": [0.0, 0.01, 0.02], "speed": [1.0, 1.0, 1.0]}).to_csv(path, index=False)
    code = main(["fit-tyre", str(path), "--vehicle", "compact_fwd", "--json"])
    assert code == 2
    assert "missing required columns" in _one_line_error(capsys)


def test_unknown_vehicle(tmp_path, capsys):
    path = tmp_path / "bad.csv"
    pd.DataFrame({"time": [0.0, 0.01]}).to_csv(path, index=False)
    code = main(["fit-tyre", str(path), "--vehicle", "tractor_9000"])
    assert code == 2
    assert "tractor_9000" in _one_line_error(capsys)


@pytest.mark.slow
def test_fast_fit_of_a_simulated_drive(tmp_path, capsys):
    from tyrebayes.simulate.drive import simulate_drive
    from tyrebayes.simulate.profiles import ProfileOptions
    from tyrebayes.streams import write_stream

    df, truth = simulate_drive(
        3, "compact_fwd", "summer", duration_s=300.0, profile=ProfileOptions(n_abs_events=1)
    )
    stream = tmp_path / "drive.csv"
    write_stream(df, stream)
    out = tmp_path / "fit.nc"
    code = main(
        [
            "fit-tyre",
            str(stream),
            "--vehicle",
            "compact_fwd",
            "--method",
            "fast",
            "--json",
            "--out",
            str(out),
        ]
    )
    payload = json.loads(capsys.readouterr().out)
    assert code == 0
    for key in ("c_x", "c_xr", "mu_max", "slip_offset", "force_gain"):
        assert set(payload[key]) == {"mean", "sd", "hdi_90"}
    assert {"r_hat_max", "ess_min", "divergences", "converged"} <= set(payload["diagnostics"])
    assert payload["mu_max_observed"] is True
    assert payload["n_samples_used"] > 100
    assert out.is_file() and not list(tmp_path.glob(".*tmp*"))


def test_model_choices_are_the_model_kinds():
    from tyrebayes._commands.fit_tyre import MODEL_CHOICES
    from tyrebayes.inference.tyre_model import DEFAULT_KIND, MODEL_KINDS

    assert set(MODEL_CHOICES) == set(MODEL_KINDS) and MODEL_CHOICES[0] == DEFAULT_KIND
