"""``tyrebayes convert`` end to end, bad logs (exit 2, no output), and --profile elsewhere."""

from __future__ import annotations

import json

import can
import numpy as np
import pandas as pd
import pytest

from tyrebayes.cli import main
from tyrebayes.simulate.can_log import write_can_log


def _run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_convert_json(messages, drive, tmp_path, capsys):
    log = write_can_log(messages, tmp_path / "drive.blf")
    out = tmp_path / "stream.parquet"
    argv = ["convert", str(log), "--profile", "toyota_rav4_2017", "--out", str(out), "--json"]
    code, stdout, _ = _run(capsys, argv)
    assert code == 0
    summary = json.loads(stdout)
    n = len(drive)
    assert summary["frames_read"] == 4 * n
    assert summary["frames_used_per_message"]["WHEEL_SPEEDS"] == n
    assert summary["samples"] == n
    assert summary["channel_rate_hz"]["ax"] == pytest.approx(50.0, rel=1e-5)
    assert summary["nan_fraction"]["wheel_speed_fl"] == 0.0
    stream = pd.read_parquet(out)
    assert stream.shape[0] == n
    np.testing.assert_allclose(stream["ax"], drive["ax"], atol=0.5 * 0.03589 + 1e-9)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive.blf", "stream.parquet"]
    # Human text names the frames and rates.
    code, stdout, _ = _run(capsys, argv[:-1])
    assert code == 0 and f"{n} samples" in stdout and "WHEEL_SPEEDS" in stdout


def _bad_logs(messages, profile, tmp_path):
    """Each bad log (path, extra args) and the phrase its error must contain."""
    good = write_can_log(messages, tmp_path / "good.log")
    text = good.read_text()
    truncated = tmp_path / "truncated.log"
    truncated.write_text(text[: len(text) // 2 + 7])
    garbage = tmp_path / "garbage.log"
    lines = text.splitlines()
    garbage.write_text("\n".join(lines[:10] + ["$$ garbage $$"] + lines[10:]) + "\n")
    shipped = profile.dbc_path().read_text()
    # A DBC of another car: WHEEL_SPEEDS under another identifier, KINEMATICS 6 bytes long.
    other_id = tmp_path / "other_id.dbc"
    other_id.write_text(shipped.replace("BO_ 170 WHEEL_SPEEDS: 8", "BO_ 171 WHEEL_SPEEDS: 8"))
    other_length = tmp_path / "other_length.dbc"
    other_length.write_text(shipped.replace("BO_ 36 KINEMATICS: 8", "BO_ 36 KINEMATICS: 6"))
    no_steer = write_can_log(
        [m for m in messages if m.arbitration_id != 0x25], tmp_path / "nosteer.log"
    )
    out_of_range = []
    for k, m in enumerate(messages):
        if m.arbitration_id == 0x25 and k > 40:
            data = bytearray(m.data)
            data[4] = (data[4] & 0x0F) | 0x80  # STEER_FRACTION = -0.8 deg, DBC range ±0.7
            m = can.Message(
                timestamp=m.timestamp, arbitration_id=0x25, data=bytes(data), channel=m.channel
            )
        out_of_range.append(m)
    out_of_range = write_can_log(out_of_range, tmp_path / "range.log")
    return [
        (truncated, [], "truncated file"),
        (garbage, [], "line 11: expected"),
        (good, ["--dbc", str(other_id)], "WHEEL_SPEEDS (0xAB), got none"),
        (good, ["--dbc", str(other_length)], "the DBC does not match: message KINEMATICS"),
        (no_steer, [], "STEER_ANGLE_SENSOR (0x25), got none"),
        (out_of_range, [], "STEER_FRACTION"),
        (good, ["--bus", "can3"], "on bus 'can3'"),
    ]


def test_bad_logs_exit_2_with_one_line_and_no_output(messages, profile, tmp_path, capsys):
    cases = _bad_logs(messages, profile, tmp_path)
    for k, (log, extra, phrase) in enumerate(cases):
        out = tmp_path / f"out{k}.parquet"
        argv = ["convert", str(log), "--profile", "toyota_rav4_2017", "--out", str(out), *extra]
        code, stdout, stderr = _run(capsys, argv)
        assert code == 2, (log.name, stderr)
        assert stderr.count("\n") == 1 and phrase in stderr, (log.name, stderr)
        assert stdout == ""
        assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if "out" in p.name]  # no temporary either


def test_inspect_takes_a_can_log(messages, tmp_path, capsys):
    log = write_can_log(messages, tmp_path / "drive.log")
    argv = ["inspect", str(log), "--vehicle", "suv_rav4", "--profile", "toyota_rav4_2017"]
    code, stdout, _ = _run(capsys, [*argv, "--json"])
    assert code == 0
    summary = json.loads(stdout)
    assert summary["file"] == str(log)
    assert summary["samples"] == len(messages) // 4
    code, _, stderr = _run(capsys, ["inspect", str(log), "--vehicle", "suv_rav4", "--dbc", "x"])
    assert code == 2 and "--dbc: expected together with --profile" in stderr


def test_criticize_stream_takes_a_can_log(rav4, profile, db, tmp_path, capsys):
    """The same answer from the CAN log with --profile as from the decoded table's file."""
    from tyrebayes.simulate.can_log import stream_messages
    from tyrebayes.streams import write_stream
    from tyrebayes.streams.can import read_can_log
    from tyrebayes.streams.synthetic import synthetic_stream

    df, _ = synthetic_stream(rav4, duration_s=40.0, rate_hz=50.0, seed=5)
    msgs = stream_messages(df, profile, db, wheel_radius_m=rav4.wheel_radius_m)
    log = write_can_log(msgs, tmp_path / "drive.log")
    decoded = tmp_path / "decoded.parquet"
    write_stream(read_can_log(log, profile).data, decoded)
    answers = []
    for argv in (
        [str(log), "--profile", "toyota_rav4_2017"],
        [str(decoded)],
    ):
        code, stdout, _ = _run(
            capsys, ["criticize-stream", *argv, "--vehicle", "suv_rav4", "--json"]
        )
        assert code == 0
        answers.append(json.loads(stdout))
    assert answers[0] == answers[1]
    assert answers[0]["baseline"]["elpd"] is not None


def test_fit_tyre_takes_a_can_log(rav4, profile, db, tmp_path, capsys, monkeypatch):
    """fit-tyre --profile fits the windows of the decoded log (the fit itself is stubbed out)."""
    import tyrebayes.inference.tyre.fit as tyre_fit
    from tyrebayes import BadInputError
    from tyrebayes.inference.tyre.data import observations_from_stream
    from tyrebayes.simulate.can_log import stream_messages
    from tyrebayes.streams import write_stream
    from tyrebayes.streams.can import read_can_log
    from tyrebayes.streams.synthetic import synthetic_stream

    df, _ = synthetic_stream(rav4, duration_s=60.0, rate_hz=50.0, seed=6)
    msgs = stream_messages(df, profile, db, wheel_radius_m=rav4.wheel_radius_m)
    log = write_can_log(msgs, tmp_path / "drive.blf")
    seen = []

    def stub(obs, **kwargs):
        seen.append(obs)
        raise BadInputError("stub: fit skipped")

    monkeypatch.setattr(tyre_fit, "fit_tyre", stub)
    argv = [str(log), "--profile", "toyota_rav4_2017", "--vehicle", "suv_rav4", "--method", "fast"]
    code, _, stderr = _run(capsys, ["fit-tyre", *argv, "--json"])
    assert code == 2 and "stub: fit skipped" in stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["drive.blf"]  # temporary file removed
    decoded = tmp_path / "decoded.parquet"
    write_stream(read_can_log(log, profile).data, decoded)
    expected = observations_from_stream(decoded, "suv_rav4")
    np.testing.assert_array_equal(np.asarray(seen[0].slip), np.asarray(expected.slip))
