"""``tyrebayes fit-tyre``: bad inputs exit 2 with one line; a full run on a simulated drive."""

import json

import numpy as np
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
    assert {"r_hat_max", "ess_bulk_min", "divergences", "converged"} <= set(payload["diagnostics"])
    assert payload["converged"] is True and isinstance(payload["adequate"], bool)
    assert payload["mu_max_observed"] is True
    assert payload["n_samples_used"] > 100
    assert out.is_file() and not list(tmp_path.glob(".*tmp*"))


def test_model_choices_are_the_model_kinds():
    from tyrebayes._commands.fit_tyre import MODEL_CHOICES
    from tyrebayes.inference.tyre.model import CURVE_MODELS, DEFAULT_MODEL

    assert set(MODEL_CHOICES) == set(CURVE_MODELS) and MODEL_CHOICES[0] == DEFAULT_MODEL


def test_fit_tyre_exits_3_when_the_fit_did_not_converge(tmp_path, capsys, monkeypatch):
    """The command's contract for a failed fit: exit 3, the reason on stderr, the fit written."""
    from tyrebayes._resources import data_dir
    from tyrebayes.inference.result import load_fit
    from tyrebayes.inference.tyre import fit as tyre_fit
    from tyrebayes.inference.tyre.data import stack_drives

    from .inference.tyre.test_model import PAD, linear_region_windows

    # A fit that did not converge (non-finite forces), of the shape the inference tests compile.
    windows = linear_region_windows(3)
    windows = windows.replace(rho=np.where(np.arange(len(windows)) < 10, np.inf, windows.rho))
    failed = tyre_fit.fit_tyre(stack_drives([windows], ["dry"], pad_to=PAD), method="fast")
    assert not failed.converged
    monkeypatch.setattr(tyre_fit, "fit_tyre", lambda *args, **kwargs: failed)
    out = tmp_path / "fit.nc"
    stream = data_dir() / "comma2k19_rav4_segment.csv"
    argv = ["fit-tyre", str(stream), "--vehicle", "suv_rav4", "--method", "fast"]
    code = main([*argv, "--json", "--out", str(out)])
    captured = capsys.readouterr()
    payload = json.loads(captured.out)
    assert code == 3 and payload["converged"] is False
    assert "did not converge" in captured.err and "non-finite" in captured.err
    assert load_fit(out, kind="tyre").converged is False
    code = main(argv)
    assert code == 3 and "NOT CONVERGED" in capsys.readouterr().out


def test_load_sensitivity_flag_gives_the_fit_the_measured_prior(tmp_path, capsys, monkeypatch):
    """``--load-sensitivity`` reaches the fit as the measured tyres' q prior and its provenance."""
    from tyrebayes._resources import data_dir
    from tyrebayes.inference.result import load_fit
    from tyrebayes.inference.tyre import fit as tyre_fit
    from tyrebayes.inference.tyre.data import stack_drives

    from .inference.tyre.test_model import PAD, linear_region_windows

    fit = tyre_fit.fit_tyre(
        stack_drives([linear_region_windows(3)], ["dry"], pad_to=PAD), method="fast"
    )
    given = {}

    def recording(*args, **kwargs):
        given.update(kwargs)
        return fit

    monkeypatch.setattr(tyre_fit, "fit_tyre", recording)
    out = tmp_path / "fit.nc"
    stream = data_dir() / "comma2k19_rav4_segment.csv"
    argv = ["fit-tyre", str(stream), "--vehicle", "suv_rav4", "--method", "fast", "--json"]
    assert main([*argv, "--load-sensitivity", "--out", str(out)]) == 0
    payload = json.loads(capsys.readouterr().out)
    # the real RAV4's highway minute has no cornering to speak of: no lateral numbers
    assert payload["lateral"] is None
    assert payload["lateral_reason"].startswith("lateral: no usable cornering")
    assert given["priors"].load_sensitive and given["priors"].load_sensitivity_sd == 0.246
    assert json.loads(load_fit(out).provenance.settings)["load_sensitivity"] is True
    capsys.readouterr()
    assert main(argv) == 0 and given["priors"] is None


def test_fit_tyre_validates_the_stream_once(tmp_path, capsys, monkeypatch):
    """The command's flags, its lateral fit and its longitudinal windows read one validation."""
    from tyrebayes import streams
    from tyrebayes._resources import data_dir
    from tyrebayes.inference.tyre import fit as tyre_fit
    from tyrebayes.inference.tyre.data import stack_drives

    from .inference.tyre.test_model import PAD, linear_region_windows

    fit = tyre_fit.fit_tyre(
        stack_drives([linear_region_windows(3)], ["dry"], pad_to=PAD), method="fast"
    )
    monkeypatch.setattr(tyre_fit, "fit_tyre", lambda *args, **kwargs: fit)
    calls = []
    validate = streams.validate_stream

    def counting(*args, **kwargs):
        calls.append(args)
        return validate(*args, **kwargs)

    monkeypatch.setattr(streams, "validate_stream", counting)
    stream = data_dir() / "comma2k19_rav4_segment.csv"
    argv = ["fit-tyre", str(stream), "--vehicle", "suv_rav4", "--method", "fast", "--json"]
    assert main(argv) == 0
    assert json.loads(capsys.readouterr().out)["n_samples_used"] > 0
    assert len(calls) == 1


def _slow_stream(path):
    from tyrebayes._domain import load_vehicle
    from tyrebayes.streams import write_stream
    from tyrebayes.streams.synthetic import synthetic_stream

    df, _ = synthetic_stream(load_vehicle("compact_fwd"), duration_s=120.0, rate_hz=10.0, seed=1)
    write_stream(df, path)
    return path


def test_stream_flags_are_read_for_the_fit(tmp_path):
    from tyrebayes._commands.fit_tyre import _validated

    validated, _ = _validated(_slow_stream(tmp_path / "slow.csv"), "compact_fwd")
    (flag,) = validated.flags
    assert flag.startswith("sample rate 10 Hz")


@pytest.mark.slow
def test_fit_carries_the_stream_flags(tmp_path, capsys):
    from tyrebayes.inference.result import load_fit

    path, out = _slow_stream(tmp_path / "slow.csv"), tmp_path / "fit.nc"
    argv = ["fit-tyre", str(path), "--vehicle", "compact_fwd", "--method", "fast"]
    assert main([*argv, "--json", "--out", str(out)]) == 0
    (flag,) = json.loads(capsys.readouterr().out)["stream_flags"]
    assert flag.startswith("sample rate 10 Hz")
    assert "sample rate 10 Hz" in json.loads(load_fit(out).provenance.settings)["stream_flags"]


def test_diagnostics_text_has_no_r_hat_for_independent_draws():
    from tyrebayes._commands._common import diagnostics_text
    from tyrebayes.inference.diagnostics import Diagnostics

    common = {
        "n_chains": 1,
        "n_draws": 2000,
        "ess_bulk_min": 2000.0,
        "ess_tail_min": 2000.0,
        "divergences": 0,
        "optimiser_result": "successful",
        "converged": True,
        "reasons": (),
    }
    fast = diagnostics_text(Diagnostics(method="fast", r_hat_max=float("nan"), **common))
    assert "R-hat max –," in fast and "nan" not in fast.lower()
    nuts = diagnostics_text(Diagnostics(method="nuts", r_hat_max=1.0042, **common))
    assert "R-hat max 1.004," in nuts


def _cornering_stream(path, **changes):
    from tyrebayes._domain import load_vehicle
    from tyrebayes.simulate.cornering import simulate_cornering
    from tyrebayes.streams import write_stream

    frame, truth = simulate_cornering(load_vehicle("compact_fwd"), duration_s=240.0, seed=11)
    for column, factor in changes.items():
        frame[column] = frame[column] * factor
    write_stream(frame, path)
    return path, truth


@pytest.mark.early
def test_fit_tyre_prints_and_saves_the_lateral_fit(tmp_path, capsys, monkeypatch):
    """The CLI end to end for the lateral part (the longitudinal fit stubbed as above)."""
    from tyrebayes.inference.result import load_fit
    from tyrebayes.inference.tyre import fit as tyre_fit
    from tyrebayes.inference.tyre.data import stack_drives
    from tyrebayes.inference.tyre.result import TyreFit

    from .inference.tyre.test_model import PAD, linear_region_windows

    fit = tyre_fit.fit_tyre(
        stack_drives([linear_region_windows(3)], ["dry"], pad_to=PAD), method="fast"
    )
    monkeypatch.setattr(tyre_fit, "fit_tyre", lambda *args, **kwargs: fit)
    stream, truth = _cornering_stream(tmp_path / "corners.csv")
    out = tmp_path / "fit.nc"
    argv = ["fit-tyre", str(stream), "--vehicle", "compact_fwd", "--method", "fast"]
    assert main([*argv, "--json", "--out", str(out)]) == 0
    lateral = json.loads(capsys.readouterr().out)["lateral"]
    for key in ("c_y_front", "c_y_rear", "understeer_gradient", "steering_ratio"):
        assert set(lateral[key]) == {"mean", "sd", "hdi_90"}, key
    assert lateral["mu_y"] is None and lateral["mu_y_observed"] is False
    assert lateral["converged"] is True and isinstance(lateral["adequate"], bool)
    lo, hi = lateral["understeer_gradient"]["hdi_90"]
    assert lo <= truth.understeer_gradient <= hi
    saved = TyreFit.from_fit(load_fit(out, kind="tyre")).lateral
    assert saved is not None and saved.to_dict() == lateral
    assert main(argv) == 0 and "c_y front" in capsys.readouterr().out
    # the report of the saved fit has the cornering section
    report = tmp_path / "report"
    assert main(["report", str(out), "--out", str(report)]) == 0
    assert "Cornering" in (report / "report.html").read_text()
    assert (report / "figures" / "lateral_curves.png").stat().st_size > 5_000


@pytest.mark.parametrize(
    ("change", "named"),
    [({"ay": -1.0}, "ay"), ({"steering_wheel_angle": 57.29577951308232}, "steering")],
)
def test_a_flipped_ay_or_steering_in_degrees_is_refused(tmp_path, capsys, change, named):
    stream, _ = _cornering_stream(tmp_path / "bad.csv", **change)
    argv = ["fit-tyre", str(stream), "--vehicle", "compact_fwd", "--method", "fast"]
    assert main(argv) == 2
    err = _one_line_error(capsys)
    assert named in err, err
