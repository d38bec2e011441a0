"""CAN time faults (issue 57): frames out of time order, duplicated frames and reversed logs are
counted per message, refused above ``--max-time-faults`` and repaired below it, never re-sorted
silently.

Before, a converter sorted every message by time: 500 frames stamped 5 s early were sorted into
the wrong instants (wheel speeds off by up to 7.5 rad/s, exit 0, no note), and a reversed log or
one with every frame twice went through without a word.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tyrebayes import BadInputError
from tyrebayes.cli import main
from tyrebayes.simulate.can_log import write_can_log
from tyrebayes.streams.can import read_can_log
from tyrebayes.streams.can.time_faults import repair_time_faults

PROFILE = "toyota_rav4_2017"


def _payloads(n: int) -> np.ndarray:
    return np.arange(n, dtype=np.uint8)[:, None].repeat(2, axis=1)


def test_a_sound_message_has_no_faults():
    t = np.arange(100) * 0.01
    faults, keep = repair_time_faults(t, _payloads(100))
    assert faults.faulty == 0 and faults.fraction == 0.0 and not faults.reversed
    np.testing.assert_array_equal(keep, np.arange(100))


def test_frames_stamped_early_are_dropped_not_sorted_in():
    t = np.arange(1000) * 0.01
    t[400:450] -= 2.0  # a clock stepped back for 50 frames
    faults, keep = repair_time_faults(t, _payloads(1000))
    assert (faults.out_of_order, faults.duplicates) == (50, 0)
    assert faults.largest_backward_s == pytest.approx(2.0, abs=0.011)
    # The frames kept go forward and are the ones with their own timestamps.
    np.testing.assert_array_equal(keep, np.r_[0:400, 450:1000])


def test_one_glitch_into_the_future_costs_one_frame():
    t = np.arange(1000) * 0.01
    t[500] += 3600.0
    faults, keep = repair_time_faults(t, _payloads(1000))
    assert faults.out_of_order == 1 and keep.size == 999 and 500 not in keep


def test_a_reversed_message_is_sorted_and_said_so():
    t = (np.arange(200) * 0.01)[::-1].copy()
    faults, keep = repair_time_faults(t, _payloads(200))
    assert faults.reversed and faults.out_of_order == 199 and faults.fraction > 0.99
    assert np.all(np.diff(t[keep]) > 0) and keep.size == 200
    assert "a reversed log?" in faults.describe("WHEEL_SPEEDS")


def test_duplicated_frames_keep_their_first_copy():
    t = np.repeat(np.arange(100) * 0.01, 2)
    faults, keep = repair_time_faults(t, np.repeat(_payloads(100), 2, axis=0))
    assert faults.duplicates == 100 and faults.out_of_order == 0 and faults.fraction == 0.5
    np.testing.assert_array_equal(keep, np.arange(0, 200, 2))


def test_frames_sharing_a_timestamp_with_other_payloads_are_no_fault():
    # comma's logs bundle a message's frames at one timestamp now and then.
    t = np.array([0.0, 0.01, 0.01, 0.02, 0.03])
    faults, keep = repair_time_faults(t, _payloads(5))
    assert faults.faulty == 0 and faults.shared_timestamps == 1 and keep.size == 5


def _candump(frames, path):
    """A candump log of (timestamp, message) in the order given.

    Written by hand: python-can's own candump writer stamps a frame whose time goes back with
    an earlier frame's time, which would hide the fault under test.
    """
    lines = [f"({t:.6f}) can0 {m.arbitration_id:03X}#{bytes(m.data).hex().upper()}\n"
             for t, m in frames]  # fmt: skip
    path.write_text("".join(lines))
    return path


def _shift(messages, rows, dt):
    rows = set(rows)
    return [(m.timestamp + (dt if i in rows else 0.0), m) for i, m in enumerate(messages)]


def _as_is(messages):
    return [(m.timestamp, m) for m in messages]


def test_read_can_log_refuses_above_the_allowance_and_repairs_below(messages, tmp_path):
    # 400 frames per message; 8 consecutive frames (2 per message, 0.5 %) stamped 1 s early.
    mid = len(messages) // 2
    log = _candump(_shift(messages, range(mid, mid + 8), -1.0), tmp_path / "back.log")
    conv = read_can_log(log, PROFILE)
    faults = conv.time_faults["WHEEL_SPEEDS"]
    assert (faults.out_of_order, faults.duplicates) == (2, 0)
    assert conv.time_faults_repaired == 8
    assert conv.frames_per_message["WHEEL_SPEEDS"] == faults.frames - 2
    assert np.all(np.diff(conv.data["time"]) > 0)
    assert "WHEEL_SPEEDS: 2 of 400 frames out of order" in conv.time_faults_text()
    with pytest.raises(BadInputError) as err:
        read_can_log(log, PROFILE, max_time_faults=0.0)
    message = str(err.value)
    assert "expected timestamps that go forward, got WHEEL_SPEEDS: 2 of 400" in message
    assert "above the 0 % allowed" in message and "\n" not in message
    with pytest.raises(BadInputError, match=r"max_time_faults: expected a fraction"):
        read_can_log(log, PROFILE, max_time_faults=5.0)


def _convert(capsys, log, out, *extra):
    argv = ["convert", str(log), "--profile", PROFILE, "--out", str(out), "--json", *extra]
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.parametrize(
    ("name", "reason"),
    [("reversed", "a reversed log?"), ("twice", "400 of 800 frames duplicated")],
)
def test_convert_refuses_reversed_and_doubled_logs(messages, tmp_path, capsys, name, reason):
    frames = _as_is(messages)
    faulty = frames[::-1] if name == "reversed" else [f for f in frames for _ in (0, 1)]
    log = _candump(faulty, tmp_path / f"{name}.log")
    out = tmp_path / "out.parquet"
    code, stdout, err = _convert(capsys, log, out)
    assert code == 2 and stdout == "" and err.count("\n") == 1 and reason in err, err
    assert "expected timestamps that go forward" in err and not out.exists()
    # Allowed in full, the same log is repaired: the stream equals the sound log's.
    code, stdout, err = _convert(capsys, log, out, "--max-time-faults", "1")
    assert code == 0, err
    summary = json.loads(stdout)
    assert summary["time_faults_repaired"] > 0 and summary["max_time_faults"] == 1.0
    assert err.startswith("tyrebayes convert: warning: CAN time faults repaired: WHEEL_SPEEDS")
    assert err.count("\n") == 1
    sound = tmp_path / "sound.parquet"
    assert _convert(capsys, _candump(frames, tmp_path / "sound.log"), sound)[0] == 0
    import pandas as pd

    pd.testing.assert_frame_equal(pd.read_parquet(out), pd.read_parquet(sound))


def test_convert_json_counts_a_repair_and_warns(messages, tmp_path, capsys):
    mid = len(messages) // 2
    log = _candump(_shift(messages, range(mid, mid + 4), -1.0), tmp_path / "back.log")
    code, stdout, err = _convert(capsys, log, tmp_path / "out.parquet")
    assert code == 0, err
    faults = json.loads(stdout)["time_faults"]
    assert set(faults) == {"WHEEL_SPEEDS", "KINEMATICS", "STEER_ANGLE_SENSOR", "SPEED"}
    assert sum(f["out_of_order"] for f in faults.values()) == 4
    assert all(f["duplicates"] == 0 and not f["reversed"] for f in faults.values())
    assert err.count("\n") == 1 and "1 of 400 frames out of order (up to 0.98 s back)" in err
    # A sound log: all zero, and nothing on stderr.
    sound = write_can_log(messages, tmp_path / "sound.log")
    code, stdout, err = _convert(capsys, sound, tmp_path / "sound.parquet")
    assert code == 0 and err == ""
    assert json.loads(stdout)["time_faults_repaired"] == 0


def test_max_time_faults_option_errors_are_one_line(messages, tmp_path, capsys):
    log = write_can_log(messages, tmp_path / "sound.log")
    with pytest.raises(SystemExit) as info:
        main(["convert", str(log), "--profile", PROFILE, "--out", "x.parquet",
              "--max-time-faults", "5"])  # fmt: skip
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.count("\n") == 1 and "percentage? divide by 100" in err
    argv = ["inspect", str(log), "--vehicle", "suv_rav4", "--max-time-faults", "0.1"]
    assert main(argv) == 2
    assert "--max-time-faults: expected together with --profile" in capsys.readouterr().err
