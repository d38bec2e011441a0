"""Property: random corruption of a valid stream *file* never yields a silent wrong answer.

The bytes of a valid CSV are corrupted the ways files get damaged in practice (a truncated
write, lost or repeated lines, lines out of order, a flipped byte, a mangled number or cell, a
damaged header). Reading, validating and processing the damaged file must then either raise
:class:`tyrebayes.BadInputError` with one line, or give features that agree with the clean file
wherever both claim validity (V_x and ρ_x with the tolerances of the table-level property test
in ``test_validate.py``, and the driven-axle slip).

Known limit, pinned by the strict xfail below: one value cell changed to another *plausible*
number (a changed digit, a zero) is a single-sample outlier that validation does not yet detect
(it needs a despiking step that respects ABS wheel dynamics); the property therefore changes
digits only in the time column and flips bytes only to characters that cannot form a number.
"""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from tyrebayes import BadInputError
from tyrebayes._domain import load_vehicle
from tyrebayes.streams import (
    StreamFeatures,
    compute_features,
    read_stream,
    validate_stream,
    write_stream,
)
from tyrebayes.streams.synthetic import synthetic_stream

VEHICLE = load_vehicle("compact_fwd")


@functools.cache
def _clean() -> tuple[bytes, StreamFeatures]:
    """The valid file's bytes and its features (module cache: no fixture in the hypothesis repr)."""
    df, _ = synthetic_stream(VEHICLE, duration_s=30.0, rate_hz=50.0, seed=3)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "clean.csv"
        write_stream(df, path)
        feats = compute_features(validate_stream(read_stream(path), VEHICLE), VEHICLE)
        return path.read_bytes(), feats


def _lines(data: bytes) -> list[bytes]:
    return data.split(b"\n")


def _corrupt(data: bytes, how: tuple) -> bytes:
    damage = how[0]
    lines = _lines(data)
    body = len(lines) - 2  # header first, empty string after the final newline
    if damage == "truncate":  # a write cut short
        return data[: int(how[1] * len(data))]
    if damage == "flip":  # one byte replaced by a character that cannot be part of a number
        pos = int(how[1] * (len(data) - 1))
        return data[:pos] + _NOT_NUMERIC[how[2] % len(_NOT_NUMERIC)] + data[pos + 1 :]
    if body < 3:
        return data  # already cut to (almost) nothing by an earlier truncation
    row = 1 + int(how[1] * (body - 1))
    if damage == "drop_line":
        del lines[row]
    elif damage == "repeat_line":
        lines.insert(row, lines[row])
    elif damage == "swap_lines":
        lines[row], lines[row + 1] = lines[row + 1], lines[row]
    elif damage == "cell":  # one cell replaced by text, an empty cell, or another number
        cells = lines[row].split(b",")
        cells[how[2] % len(cells)] = how[3]
        lines[row] = b",".join(cells)
    elif damage == "digit":  # one digit of one time stamp changed
        cells = lines[row].split(b",")
        col = 0
        digits = [i for i, ch in enumerate(cells[col]) if chr(ch).isdigit()]
        if digits:
            i = digits[how[3] % len(digits)]
            cells[col] = cells[col][:i] + str(how[4]).encode() + cells[col][i + 1 :]
        lines[row] = b",".join(cells)
    elif damage == "header":  # a column name damaged
        names = lines[0].split(b",")
        names[how[2] % len(names)] = b"x" + names[how[2] % len(names)]
        lines[0] = b",".join(names)
    return b"\n".join(lines)


_NOT_NUMERIC = [bytes([c]) for c in b"abcdfghijklmnopqrstuvwxyz#%!?@&*;:"]
fraction = st.floats(0.0, 0.999)
corruption = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0.0, 0.99)),
    st.tuples(st.just("flip"), fraction, st.integers(32, 126)),
    st.tuples(st.sampled_from(["drop_line", "repeat_line", "swap_lines"]), fraction),
    st.tuples(
        st.just("cell"),
        fraction,
        st.integers(0, 20),
        st.sampled_from([b"", b"nan", b"abc", b"1e9", b"-1e3", b"12,5"]),
    ),
    st.tuples(
        st.just("digit"), fraction, st.integers(0, 20), st.integers(0, 30), st.integers(0, 9)
    ),
    st.tuples(st.just("header"), st.just(0.0), st.integers(0, 20)),
)


@settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(st.lists(corruption, min_size=1, max_size=2))
def test_file_corruption_is_caught_or_harmless(corruptions):
    data, ref = _clean()
    for how in corruptions:
        data = _corrupt(data, how)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "stream.csv"
            path.write_bytes(data)
            feats = compute_features(validate_stream(read_stream(path), VEHICLE), VEHICLE)
    except BadInputError as err:
        assert "\n" not in str(err)
        event(f"rejected: {str(err).split(':')[0][:40]}")
        return
    event("accepted")
    # Not rejected: the answer must agree with the clean file wherever both claim validity.
    t = np.interp(ref.time_s, feats.time_s, feats.time_s)  # same base unless a line was lost
    assert feats.time_s.shape == ref.time_s.shape or np.all(np.isfinite(t))
    vx = np.interp(ref.time_s, feats.time_s, np.nan_to_num(feats.vx_mps, nan=-1e3))
    rho = np.interp(ref.time_s, feats.time_s, np.nan_to_num(feats.rho_driven, nan=-1e3))
    valid = np.interp(ref.time_s, feats.time_s, feats.valid.astype(float)) > 0.999
    both = valid & ref.valid & (vx > -1e2) & (rho > -1e2)
    # A truncated file ends where the clean one goes on: its last samples are smoothed over a
    # one-sided window, as every log's last ones are (the clean file's at its own end).
    end = feats.time_s[-1] - (feats.time_s[-1] < ref.time_s[-1]) * feats.smoothing_s
    both &= (ref.time_s >= feats.time_s[0]) & (ref.time_s <= end)
    assert both.sum() > 50
    assert np.max(np.abs(vx[both] - ref.vx_mps[both])) < 0.05
    rho_ok = both & np.isfinite(ref.rho_driven)
    assert np.median(np.abs(rho[rho_ok] - ref.rho_driven[rho_ok])) < 0.01
    assert np.max(np.abs(rho[rho_ok] - ref.rho_driven[rho_ok])) < 0.05
    slip = np.interp(ref.time_s, feats.time_s, np.nan_to_num(feats.slip_driven, nan=-1e3))
    slip_ok = both & np.isfinite(ref.slip_driven) & (slip > -1e2)
    assert np.max(np.abs(slip[slip_ok] - ref.slip_driven[slip_ok])) < 5e-3


@pytest.mark.xfail(strict=True, reason="single-sample outliers are not despiked yet (known limit)")
def test_single_plausible_outlier_in_a_wheel_speed_is_caught_or_harmless():
    data, ref = _clean()
    lines = _lines(data)
    cells = lines[700].split(b",")
    cells[1] = b"0"  # front-left wheel speed: one sample of a stopped wheel at 25 m/s
    lines[700] = b",".join(cells)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "stream.csv"
        path.write_bytes(b"\n".join(lines))
        try:
            feats = compute_features(validate_stream(read_stream(path), VEHICLE), VEHICLE)
        except BadInputError:
            return
    ok = feats.valid & ref.valid
    assert np.nanmax(np.abs(feats.slip_driven[ok] - ref.slip_driven[ok])) < 5e-3
