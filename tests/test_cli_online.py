"""``tyrebayes online``: end to end on a short simulated drive, and bad input."""

import json

import pytest

from tyrebayes.cli import main
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.simulate.profiles import ProfileOptions
from tyrebayes.streams import write_stream


@pytest.fixture(scope="module")
def short_stream(tmp_path_factory):
    path = tmp_path_factory.mktemp("online") / "drive.parquet"
    df, _ = simulate_drive(
        3, "compact_fwd", "summer", duration_s=300, profile=ProfileOptions(n_abs_events=1)
    )
    write_stream(df, path)
    return path


def test_online_json_trajectory(short_stream, capsys):
    code = main(
        ["online", str(short_stream), "--vehicle", "compact_fwd", "--model", "linear", "--json"]
    )
    assert code == 0
    payload = json.loads(capsys.readouterr().out)
    trajectory = payload["trajectory"]
    assert len(trajectory) >= 5 and payload["final"] == trajectory[-1]
    # Five minutes of this drive are enough evidence for the linear model by the end.
    assert trajectory[-1]["enough_evidence"] and trajectory[-1]["c_x"]["mean"] > 0
    times = [r["time_s"] for r in trajectory]
    assert times == sorted(times)
    first = trajectory[0]
    # Thirty seconds of driving are not enough evidence: the value is withheld, with a reason.
    assert not first["enough_evidence"] and first["c_x"] is None and first["reason"]
    for r in trajectory:
        if r["enough_evidence"]:
            assert set(r["c_x"]) == {"mean", "sd", "hdi_90"}
            lo, hi = r["c_x"]["hdi_90"]
            assert lo < r["c_x"]["mean"] < hi
    assert payload["alarms_s"] == [r["time_s"] for r in trajectory if r["alarm"]]
    assert payload["alarm_kinds"] == [r["alarm_kind"] for r in trajectory if r["alarm"]]
    assert all((r["alarm_kind"] in ("swap", "change")) == r["alarm"] for r in trajectory)
    assert "whole stream" in payload["note"]
    assert payload["step_s"] == payload["max_step_s"] == 30.0
    # The output ends with the lateral object: null with the reason on a drive that does not
    # corner enough (this one's simulator is quasi-static in yaw).
    assert list(payload)[-2:] == ["lateral_reason", "lateral"]
    if payload["lateral"] is None:
        assert payload["lateral_reason"].startswith("lateral: ")


def test_online_text_and_bad_input(short_stream, capsys, tmp_path):
    assert main(["online", str(short_stream), "--vehicle", "compact_fwd", "--model", "linear"]) == 0
    out = capsys.readouterr().out
    assert "min" in out and "alarms (swap or change) at: " in out
    assert main(["online", str(tmp_path / "missing.parquet"), "--vehicle", "compact_fwd"]) == 2
    assert "file not found" in capsys.readouterr().err
    bad = ["online", str(short_stream), "--vehicle", "compact_fwd", "--figure", "x.txt"]
    assert main(bad) == 2
    assert "--figure" in capsys.readouterr().err
    packed = ["online", str(short_stream), "--vehicle", "compact_fwd", "--max-step-s", "25"]
    assert main(packed) == 2
    err = capsys.readouterr().err.strip()
    assert "max_step_s: expected a whole multiple of 5.0 s ≥ step_s = 30.0" in err
    assert len(err.splitlines()) == 1


@pytest.mark.early  # compiles the lateral estimator
def test_online_lateral_object_on_a_cornering_drive(tmp_path):
    """The ``"lateral"`` object the command prints, on a simulated cornering drive."""
    from tyrebayes._commands.online import _lateral
    from tyrebayes._domain import load_vehicle
    from tyrebayes.simulate.cornering import simulate_cornering

    frame, truth = simulate_cornering(load_vehicle("compact_fwd"), duration_s=300.0, seed=3)
    path = tmp_path / "corners.parquet"
    write_stream(frame, path)
    out = _lateral(path, "compact_fwd", "dry")
    assert list(out) == ["lateral_reason", "lateral"]
    lateral, reason = out["lateral"], out["lateral_reason"]
    assert reason == "" and lateral["ready"] and lateral["reason"] == ""
    for key in ("c_y_front", "c_y_rear", "understeer_gradient"):
        assert set(lateral[key]) == {"mean", "sd", "hdi_90"}, key
        lo, hi = lateral[key]["hdi_90"]
        assert lo < lateral[key]["mean"] < hi
    lo, hi = lateral["understeer_gradient"]["hdi_90"]
    assert lo <= truth.understeer_gradient <= hi
