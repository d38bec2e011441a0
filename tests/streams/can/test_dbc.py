"""The vectorised decoder against cantools' own decoding, signal by signal, on random payloads."""

from __future__ import annotations

import cantools
import numpy as np
import pytest

from tyrebayes import BadInputError
from tyrebayes.streams.can.dbc import SignalLayout, decode_signal, load_dbc, signal_layout

N_FRAMES = 300


def _assert_matches_cantools(message, rng: np.random.Generator, n: int = N_FRAMES) -> int:
    """Decode random payloads both ways; return the number of signals compared."""
    data = rng.integers(0, 256, size=(n, message.length), dtype=np.uint8)
    expected = [
        message.decode(bytes(row), decode_choices=False, scaling=True, allow_truncated=False)
        for row in data
    ]
    count = 0
    for signal in message.signals:
        if signal.multiplexer_ids:
            continue
        got = decode_signal(data, signal_layout(signal))
        want = np.array([float(e[signal.name]) for e in expected])
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=0, err_msg=signal.name)
        count += 1
    return count


def test_every_signal_of_the_profile_messages(profile, db):
    rng = np.random.default_rng(0)
    names = {ch.message for ch in profile.channels}
    checked = sum(_assert_matches_cantools(db.get_message_by_name(m), rng) for m in names)
    # WHEEL_SPEEDS 8, KINEMATICS 3, STEER_ANGLE_SENSOR 3, SPEED 3.
    assert checked == 17


def _cantools_decodes(message) -> bool:
    try:
        message.decode(bytes(message.length), decode_choices=False)
    except cantools.database.errors.DecodeError:
        return False
    return True


def test_every_signal_of_the_toyota_dbc(db):
    rng = np.random.default_rng(1)
    # cantools itself cannot unpack a message whose signals overlap (PCS_HUD in this DBC).
    messages = [m for m in db.messages if _cantools_decodes(m)]
    assert len(db.messages) - len(messages) <= 2
    checked = sum(_assert_matches_cantools(m, rng, n=40) for m in messages)
    assert checked > 200


DBC_LAYOUTS = """VERSION ""

BU_: XXX

BO_ 100 INTEL: 8 XXX
 SG_ U12 : 3|12@1+ (0.5,-10) [0|0] "" XXX
 SG_ S9 : 17|9@1- (0.25,1) [0|0] "" XXX
 SG_ B1 : 63|1@1+ (1,0) [0|0] "" XXX
 SG_ S30 : 27|30@1- (1e-3,0) [0|0] "" XXX

BO_ 101 FLOATS: 8 XXX
 SG_ F32 : 0|32@1- (1,0) [0|0] "" XXX
 SG_ F32B : 39|32@0- (2,1) [0|0] "" XXX

BO_ 102 WIDE: 8 XXX
 SG_ U64 : 0|64@1+ (1,0) [0|0] "" XXX

BO_ 103 WIDEM: 8 XXX
 SG_ S64M : 7|64@0- (1,0) [0|0] "" XXX

BO_ 2147484000 EXTFD: 64 XXX
 SG_ FD_LE : 403|63@1+ (1,0) [0|0] "" XXX
 SG_ FD_BE : 133|63@0- (0.5,0) [0|0] "" XXX
 SG_ FD_LAST : 504|8@1+ (1,0) [0|0] "" XXX

SIG_VALTYPE_ 101 F32 : 1;
SIG_VALTYPE_ 101 F32B : 1;
"""


def test_byte_orders_signs_floats_and_wide_signals():
    db = cantools.database.load_string(DBC_LAYOUTS, database_format="dbc", strict=False)
    rng = np.random.default_rng(2)
    checked = sum(_assert_matches_cantools(m, rng) for m in db.messages)
    assert checked == 11
    wide = signal_layout(db.get_message_by_name("EXTFD").get_signal_by_name("FD_LE"))
    assert wide.byte_span()[1] - wide.byte_span()[0] == 8  # spans 9 bytes: the two-part path


def test_dbc_ranges_checked_only_when_physical(db):
    steer = db.get_message_by_name("STEER_ANGLE_SENSOR")
    assert signal_layout(steer.get_signal_by_name("STEER_FRACTION")).checked_range() == (
        -0.7,
        0.7,
    )
    # opendbc writes the raw span [0|65535] for KINEMATICS: not a physical range.
    kin = db.get_message_by_name("KINEMATICS")
    assert signal_layout(kin.get_signal_by_name("ACCEL_X")).checked_range() is None
    # [0|0] is "no range" (cantools gives None).
    wheels = db.get_message_by_name("WHEEL_SPEEDS")
    assert signal_layout(wheels.get_signal_by_name("WHEEL_SPEED_FL")).checked_range() is None


def test_short_payload_and_bad_layouts(tmp_path):
    layout = SignalLayout("X", 7, 16, False, False, 1.0, 0.0, None, None, False)
    with pytest.raises(BadInputError, match="at least 2 bytes, got 1"):
        decode_signal(np.zeros((3, 1), dtype=np.uint8), layout)
    with pytest.raises(BadInputError, match="32 or 64 bits, got 16"):
        SignalLayout("F", 0, 16, True, True, 1.0, 0.0, None, None, True)
    with pytest.raises(BadInputError, match="DBC: expected a readable file"):
        load_dbc(tmp_path / "missing.dbc")
    broken = tmp_path / "broken.dbc"
    broken.write_text("BO_ this is not a dbc\n")
    with pytest.raises(BadInputError, match="DBC broken.dbc: cannot parse"):
        load_dbc(broken)
