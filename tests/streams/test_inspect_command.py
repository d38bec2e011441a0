"""`tyrebayes inspect`: JSON summary of a stream, exit code 2 with one stderr line on bad input.

(Lives beside the stream tests: the command is a thin layer over tyrebayes.streams.)
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tyrebayes._commands.inspect import summarize_stream
from tyrebayes._domain import load_vehicle
from tyrebayes._resources import data_dir
from tyrebayes.cli import main
from tyrebayes.streams import write_stream
from tyrebayes.streams.synthetic import synthetic_stream

REAL = str(data_dir() / "comma2k19_rav4_segment.csv")


def test_inspect_json_on_the_real_log(capsys):
    assert main(["inspect", REAL, "--vehicle", "suv_rav4", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("duration_s", "sample_rate_hz", "nan_fraction", "segments", "noise", "speed_error"):
        assert key in out
    assert out["duration_s"] == pytest.approx(60.0, abs=0.1)
    assert set(out["nan_fraction"]) >= {"ax", "wheel_speed_fl"}
    assert out["segments"]["traction"]["seconds"] > 0
    assert out["noise"]["ax"] > 0
    assert abs(out["speed_error"]["relative_mean"]) < 0.015


def test_inspect_text_and_dropped_samples(tmp_path, capsys):
    df, _ = synthetic_stream(
        load_vehicle("compact_fwd"),
        duration_s=20.0,
        seed=3,
        drop_fraction=0.05,
        speed_reference=False,
    )
    path = tmp_path / "drive.parquet"
    write_stream(df, path)
    summary = summarize_stream(str(path), "compact_fwd", {})
    assert "speed_error" not in summary
    assert 0 < summary["nan_fraction"]["ax"] < 0.02
    assert main(["inspect", str(path), "--vehicle", "compact_fwd"]) == 0
    assert "segments:" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("mutate", "needle"),
    [
        (lambda df: df.drop(columns=["ax"]), "missing required columns ['ax']"),
        (lambda df: df.assign(time=df["time"][::-1].to_numpy()), "non-monotonic"),
        (
            lambda df: df.assign(steering_wheel_angle=np.degrees(df["steering_wheel_angle"]) * 3),
            "degrees",
        ),
    ],
)
def test_inspect_bad_input_exit_2(tmp_path, capsys, mutate, needle):
    df, _ = synthetic_stream(load_vehicle("compact_fwd"), duration_s=20.0, seed=3)
    path = tmp_path / "bad.csv"
    write_stream(mutate(df), path)
    assert main(["inspect", str(path), "--vehicle", "compact_fwd", "--json"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert needle in captured.err and captured.err.count("\n") == 1


def test_inspect_unknown_vehicle(capsys):
    assert main(["inspect", REAL, "--vehicle", "no_such_car"]) == 2
    assert "vehicle" in capsys.readouterr().err


def test_inspect_mdf_with_channel_map(tmp_path, capsys):
    df, _ = synthetic_stream(load_vehicle("compact_fwd"), duration_s=20.0, seed=5)
    path = tmp_path / "logger.mf4"
    write_stream(df.rename(columns={"ax": "IMU_AccX", "yaw_rate": "IMU_Gz"}), path)
    argv = ["inspect", str(path), "--vehicle", "compact_fwd", "--json"]
    assert main(argv) == 2  # vendor names: required columns missing
    assert "missing required columns ['ax', 'yaw_rate']" in capsys.readouterr().err
    assert main([*argv, "--channel-map", "IMU_AccX=ax", "IMU_Gz=yaw_rate"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["sample_rate_hz"] == pytest.approx(100.0)
    assert main([*argv, "--channel-map", "IMU_AccX"]) == 2
    assert "expected SRC=DST" in capsys.readouterr().err
