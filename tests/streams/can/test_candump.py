"""The NumPy candump reader against python-can's line reader, and its errors on bad lines."""

from __future__ import annotations

import can
import numpy as np
import pytest

from tyrebayes import BadInputError
from tyrebayes.streams.can import candump
from tyrebayes.streams.can.candump import read_candump

MIXED = (
    "(1700000000.000100) can0 0AA#0102030405060708\n"
    "(1700000000.000200) can0 024#11223344 R\n"
    "(1700000000.000300) can1 12345678#DEADBEEF T\n"
    "\n"
    "(1700000000.000400) can0 025#R\n"
    "(1700000000.000500) can0 20000080#0000000000000000\n"
    "(1700000000.000600) vcan10 0B4##1A1B2C3D4E5F60718293A4B5C6D7E8F90\n"
    "(1700000000.000700) can0 0aa#ffeeddccbbaa9988\r\n"
    "(1700000000.000800) can0 7FF#\n"
    "(1700000000.000900) can1 025#R8 R\n"
    "(999.5) can0 024#00\n"
)


def _python_can(path, ids=None):
    out = []
    with can.CanutilsLogReader(str(path)) as reader:
        for msg in reader:
            if msg.is_error_frame or msg.is_remote_frame:
                continue
            if ids is None or msg.arbitration_id in ids:
                out.append((msg.timestamp, msg.arbitration_id, bytes(msg.data)))
    return out


def _ours(frames):
    return [
        (float(t), int(i), bytes(frames.data[k, : frames.length[k]]))
        for k, (t, i) in enumerate(zip(frames.time_s, frames.arbitration_id, strict=True))
    ]


@pytest.mark.parametrize("ids", [None, {0xAA, 0x24}, {0x12345678, 0xB4}])
def test_same_frames_as_python_can(tmp_path, ids):
    path = tmp_path / "mixed.log"
    path.write_bytes(MIXED.encode())
    frames, counts = read_candump(path, ids=ids)
    assert _ours(frames) == _python_can(path, ids)
    assert counts.error_frames == 1
    assert counts.remote_frames == 2
    assert counts.frames == 7


def test_bus_filter_and_bus_names(tmp_path):
    path = tmp_path / "mixed.log"
    path.write_bytes(MIXED.encode())
    frames, counts = read_candump(path, bus="can1")
    assert frames.arbitration_id.tolist() == [0x12345678]
    assert counts.buses == ("can0", "can1", "vcan10")
    assert counts.other_bus == 6


@pytest.mark.parametrize("block", [97, 16])
def test_blocks_split_lines_anywhere(tmp_path, monkeypatch, block):
    """Lines cut by the block boundary are carried to the next block (16: lines longer)."""
    rng = np.random.default_rng(4)
    lines = [
        f"({1700000000 + k * 0.001:.6f}) can0 {rng.integers(0, 0x7FF):03X}#"
        + bytes(rng.integers(0, 256, rng.integers(0, 9), dtype=np.uint8)).hex().upper()
        for k in range(500)
    ]
    path = tmp_path / "many.log"
    path.write_text("\n".join(lines) + "\n")
    whole, counts = read_candump(path)
    monkeypatch.setattr(candump, "_BLOCK_BYTES", block)
    split, split_counts = read_candump(path)
    assert _ours(split) == _ours(whole) == _python_can(path)
    assert split_counts == counts


@pytest.mark.parametrize(
    ("line", "what"),
    [
        ("hello world", r"line 2: expected '\(SECONDS\) CHANNEL ID#DATA', got 'hello world'"),
        ("(1700000000.1) can0 0AA0102", "line 2: expected '.SECONDS. CHANNEL ID#DATA'"),
        ("(1700000000.1) can0 0AAAA#0102", "line 2: expected '.SECONDS. CHANNEL ID#DATA'"),
        ("(1700000000.1) can0 0AG#0102", "line 2: expected a hex CAN identifier"),
        ("(1700000000.1) can0 0AA#010", "line 2: expected an even number of hex digits"),
        ("(1700000000.1) can0 0AA#01ZZ", "line 2: expected hex payload digits"),
        ("(17000x0000.1) can0 0AA#0102", "line 2: expected a timestamp"),
        ("(1700000000) can0 0AA#0102", r"line 2: expected a timestamp '\(SECONDS.FRACTION\)'"),
    ],
)
def test_garbage_line_names_its_number(tmp_path, line, what):
    path = tmp_path / "bad.log"
    path.write_text(f"(1700000000.000000) can0 0AA#0102\n{line}\n(1700000000.2) can0 0AA#01\n")
    with pytest.raises(BadInputError, match=what):
        read_candump(path, ids={0xAA})


def test_truncated_last_line(tmp_path):
    path = tmp_path / "cut.log"
    path.write_text("(1700000000.000000) can0 0AA#0102\n(1700000000.01")
    with pytest.raises(BadInputError, match="line 2: expected a line ending in a newline"):
        read_candump(path)
