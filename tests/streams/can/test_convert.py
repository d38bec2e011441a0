"""CAN log -> stream: round trips through python-can's writers, multi-rate, faults, bad logs."""

from __future__ import annotations

import can
import numpy as np
import pytest

from tyrebayes import BadInputError
from tyrebayes.simulate.can_log import quantisation_si, stream_messages, write_can_log
from tyrebayes.streams import read_stream, validate_stream
from tyrebayes.streams.can import read_can_log

from .conftest import EPOCH_S

# ASC writes timestamps with 6 decimals relative to the first frame; candump with 6 decimals of
# epoch seconds; float64 epoch seconds carry ~2e-7 s.
TIME_TOL_S = 2e-6


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf", ".csv", ".mf4"])
def test_round_trip_within_dbc_resolution(drive, messages, profile, db, rav4, tmp_path, suffix):
    path = write_can_log(messages, tmp_path / f"drive{suffix}")
    conv = read_can_log(path, profile)
    n = len(drive)
    assert conv.counts.frames == len(messages) == 4 * n
    assert conv.frames_per_message == {
        "WHEEL_SPEEDS": n,
        "KINEMATICS": n,
        "STEER_ANGLE_SENSOR": n,
        "SPEED": n,
    }
    assert conv.data.shape[0] == n
    t = drive["time"].to_numpy()
    np.testing.assert_allclose(conv.data["time"], t - t[0], rtol=0, atol=TIME_TOL_S)
    if suffix != ".asc":  # ASC keeps time from the start of the measurement
        assert conv.time_origin_s == pytest.approx(EPOCH_S + t[0], abs=TIME_TOL_S)
    step = quantisation_si(profile, db, rav4.wheel_radius_m)
    for column, q in step.items():
        err = np.abs(conv.data[column].to_numpy() - drive[column].to_numpy())
        # Rounding to the DBC's step: at most half a step (plus float64 noise).
        assert err.max() <= 0.5 * q * (1 + 1e-9) + 1e-12, column
    # Through the stream pipeline: same time base, same values.
    stream = validate_stream(conv.data, rav4)
    assert stream.sample_rate_hz == pytest.approx(50.0, rel=1e-5)
    np.testing.assert_allclose(
        stream.data["wheel_speed_fl"], drive["wheel_speed_fl"], atol=0.5 * step["wheel_speed_fl"]
    )


def test_multi_rate_messages_share_one_time_base(drive, profile, db, rav4, tmp_path):
    """KINEMATICS at half, SPEED at a fifth of the wheel-speed rate: resampled onto 50 Hz."""
    msgs = stream_messages(
        drive,
        profile,
        db,
        wheel_radius_m=rav4.wheel_radius_m,
        every={"KINEMATICS": 2, "SPEED": 5},
    )
    path = write_can_log(msgs, tmp_path / "multi.log")
    conv = read_can_log(path, profile)
    assert conv.frames_per_message["KINEMATICS"] == len(drive) // 2
    assert conv.frames_per_message["SPEED"] == len(drive) // 5
    stream = validate_stream(conv.data, rav4)
    assert stream.sample_rate_hz == pytest.approx(50.0, rel=1e-6)
    assert stream.channel_rate_hz["ax"] == pytest.approx(25.0, rel=1e-6)
    assert stream.channel_rate_hz["speed_reference"] == pytest.approx(10.0, rel=1e-6)
    assert stream.data.shape[0] == len(drive)
    # ax on the samples it was sent is the DBC value; between them, the linear interpolation.
    sent = np.arange(0, len(drive) - 1, 2)
    err = np.abs(stream.data["ax"].to_numpy()[sent] - drive["ax"].to_numpy()[sent])
    assert err.max() <= 0.5 * 0.03589 + 1e-9
    assert np.isfinite(stream.data["ax"].to_numpy()[: len(drive) - 1]).all()


def test_fault_bit_marks_the_sample_invalid(drive, messages, profile, tmp_path):
    faulty = []
    n_fault = 0
    for k, msg in enumerate(messages):
        if msg.arbitration_id == 0xAA and k % 40 == 0:
            data = bytearray(msg.data)
            data[2] |= 0x80  # WHEEL_SPEED_FL_FAULT: start bit 23 = byte 2, bit 7
            msg = can.Message(
                timestamp=msg.timestamp,
                arbitration_id=msg.arbitration_id,
                data=bytes(data),
                channel=msg.channel,
            )
            n_fault += 1
        faulty.append(msg)
    conv = read_can_log(write_can_log(faulty, tmp_path / "fault.log"), profile)
    assert conv.invalid_per_column["wheel_speed_fl"] == n_fault > 0
    assert conv.invalid_per_column["wheel_speed_fr"] == 0
    assert int(conv.data["wheel_speed_fl"].isna().sum()) == n_fault
    assert not conv.data["wheel_speed_fr"].isna().any()


def test_error_and_remote_frames_are_counted_and_skipped(messages, profile, tmp_path):
    extra = [
        can.Message(timestamp=messages[5].timestamp, is_error_frame=True),
        can.Message(timestamp=messages[9].timestamp, arbitration_id=0xAA, is_remote_frame=True),
        can.Message(timestamp=messages[9].timestamp, arbitration_id=0x3B7, data=bytes(8)),
    ]
    log = messages[:10] + extra + messages[10:]
    for suffix in (".log", ".asc", ".blf"):
        conv = read_can_log(write_can_log(log, tmp_path / f"mixed{suffix}"), profile)
        assert conv.counts.error_frames == 1, suffix
        assert conv.counts.remote_frames == 1, suffix
        assert conv.counts.frames == len(messages) + 1, suffix  # the 0x3B7 frame is read
        assert conv.counts.kept == len(messages), suffix


def test_bus_filter(drive, profile, db, rav4, tmp_path):
    on0 = stream_messages(drive, profile, db, wheel_radius_m=rav4.wheel_radius_m, channel="can0")
    # Another bus carrying the same identifiers with other values (a second car, a gateway).
    other = drive.copy()
    other["wheel_speed_fl"] = other["wheel_speed_fl"] + 5.0
    on1 = stream_messages(other, profile, db, wheel_radius_m=rav4.wheel_radius_m, channel="can1")
    path = write_can_log(sorted(on0 + on1, key=lambda m: m.timestamp), tmp_path / "two.log")
    conv = read_can_log(path, profile, bus="can0")
    assert conv.counts.other_bus == len(on1)
    assert conv.counts.buses == ("can0", "can1")
    step = quantisation_si(profile, db, rav4.wheel_radius_m)["wheel_speed_fl"]
    np.testing.assert_allclose(conv.data["wheel_speed_fl"], drive["wheel_speed_fl"], atol=step)
    with pytest.raises(BadInputError, match=r"on bus 'can7'.*\['can0', 'can1'\]"):
        read_can_log(path, profile, bus="can7")
    # Without a bus the two copies would interleave: refused, naming the buses.
    with pytest.raises(BadInputError, match=r"on one bus, got it on \['can0', 'can1'\]"):
        read_can_log(path, profile, bus="")
    conv_blf = read_can_log(write_can_log(on0 + on1, tmp_path / "two.blf"), profile, bus="1")
    np.testing.assert_allclose(conv_blf.data["wheel_speed_fl"], other["wheel_speed_fl"], atol=step)


def test_read_stream_dispatches_can_logs(messages, profile, tmp_path):
    path = write_can_log(messages, tmp_path / "drive.blf")
    df = read_stream(path, profile="toyota_rav4_2017")
    expected = read_can_log(path, profile).data
    assert df.equals(expected)
    with pytest.raises(BadInputError, match="channel_map or a profile"):
        read_stream(path, {"a": "b"}, profile=profile)


def test_profile_message_that_never_appears(messages, profile, tmp_path):
    no_steer = [m for m in messages if m.arbitration_id != 0x25]
    path = write_can_log(no_steer, tmp_path / "nosteer.log")
    with pytest.raises(BadInputError, match=r"STEER_ANGLE_SENSOR \(0x25\), got none"):
        read_can_log(path, profile)
    conv = read_can_log(path, profile, check_complete=False)
    assert "steering_wheel_angle" not in conv.data


def test_frames_of_another_length_mean_the_dbc_does_not_match(messages, profile, tmp_path):
    short = [
        can.Message(timestamp=m.timestamp, arbitration_id=0x24, data=m.data[:6], channel=m.channel)
        if m.arbitration_id == 0x24
        else m
        for m in messages
    ]
    path = write_can_log(short, tmp_path / "short.log")
    with pytest.raises(BadInputError, match=r"DBC does not match.*KINEMATICS.*8 bytes.*\[6\]"):
        read_can_log(path, profile)


def test_signal_outside_its_dbc_range(messages, profile, tmp_path):
    bad = []
    for m in messages:
        if m.arbitration_id == 0x25 and len(bad) > 20:
            data = bytearray(m.data)
            data[4] = (data[4] & 0x0F) | 0x80  # STEER_FRACTION raw -8 = -0.8 deg < -0.7
            m = can.Message(
                timestamp=m.timestamp, arbitration_id=0x25, data=bytes(data), channel=m.channel
            )
        bad.append(m)
    path = write_can_log(bad, tmp_path / "range.log")
    with pytest.raises(BadInputError, match=r"STEER_FRACTION.*\[-0.7, 0.7\], got -0.8"):
        read_can_log(path, profile)


def test_no_profile_frames_at_all(profile, tmp_path):
    msgs = [can.Message(timestamp=float(k), arbitration_id=0x3B7, data=bytes(8)) for k in range(5)]
    path = write_can_log(msgs, tmp_path / "other.log")
    with pytest.raises(BadInputError, match="got none of them in 5 data frames"):
        read_can_log(path, profile)


def test_a_dbc_without_the_profile_message(messages, profile, tmp_path):
    dbc = tmp_path / "other.dbc"
    dbc.write_text(
        'VERSION ""\n\nBU_:\n\nBO_ 951 OTHER: 8 XXX\n SG_ X : 7|8@0+ (1,0) [0|0] "" XXX\n'
    )
    path = write_can_log(messages, tmp_path / "drive.log")
    with pytest.raises(BadInputError, match="expects message 'WHEEL_SPEEDS' in the DBC"):
        read_can_log(path, profile, dbc=dbc)


def test_multiplexed_signals_are_refused(messages, tmp_path):
    dbc = tmp_path / "mux.dbc"
    dbc.write_text(
        'VERSION ""\n\nBU_: XXX\n\nBO_ 170 WHEEL_SPEEDS: 8 XXX\n'
        ' SG_ MUX M : 0|8@1+ (1,0) [0|0] "" XXX\n'
        ' SG_ WHEEL_SPEED_FL m1 : 8|16@1+ (0.01,0) [0|0] "km/h" XXX\n'
    )
    profile = tmp_path / "car.toml"
    profile.write_text(
        f'vehicle = "suv_rav4"\ndbc = "{dbc}"\n[channels.wheel_speed_fl]\n'
        'message = "WHEEL_SPEEDS"\nsignals = ["WHEEL_SPEED_FL"]\nunit = "km/h"\n'
    )
    path = write_can_log(messages, tmp_path / "drive.log")
    with pytest.raises(BadInputError, match="WHEEL_SPEED_FL: expected a plain signal"):
        read_can_log(path, profile)
