"""Plausibility across channels: mistakes inside every range are errors, judgements are flags.

The real RAV4 log (a straight 60 s drive) is the hard case for the steering and time checks:
its steering in degrees stays within the rad range and barely correlates with the yaw rate.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tyrebayes import BadInputError
from tyrebayes._domain import load_vehicle
from tyrebayes._resources import data_dir
from tyrebayes.cli import main
from tyrebayes.streams import read_stream, validate_stream, write_stream
from tyrebayes.streams.plausibility import (
    DROPPED_FLAG_FRACTION,
    LONG_GAP_S,
    dropped_fraction,
    sampling_flags,
)
from tyrebayes.streams.synthetic import synthetic_stream

COMPACT = load_vehicle("compact_fwd")
RAV4 = load_vehicle("suv_rav4")
REAL = read_stream(data_dir() / "comma2k19_rav4_segment.csv")


def _synthetic(**kwargs) -> pd.DataFrame:
    kwargs.setdefault("duration_s", 30.0)
    kwargs.setdefault("rate_hz", 50.0)
    return synthetic_stream(COMPACT, seed=0, **kwargs)[0]


def _error(df: pd.DataFrame, vehicle=COMPACT) -> str:
    with pytest.raises(BadInputError) as info:
        validate_stream(df, vehicle)
    message = str(info.value)
    assert "\n" not in message
    return message


def test_clean_streams_have_no_flags():
    assert validate_stream(_synthetic(), COMPACT).flags == ()
    assert validate_stream(REAL, RAV4).flags == ()


@pytest.mark.parametrize("source", ["real", "synthetic"])
def test_ax_sign_flipped(source):
    df, vehicle = (REAL, RAV4) if source == "real" else (_synthetic(), COMPACT)
    message = _error(df.assign(ax=-df["ax"]), vehicle)
    assert message.startswith("ax: expected the sign of the wheel speeds' dV_x/dt")
    assert "IMU mounted backwards" in message


def test_ay_sign_flipped_alone():
    df = _synthetic()
    message = _error(df.assign(ay=-df["ay"]))
    assert "ay vs speed x yaw_rate: expected the same sign" in message


@pytest.mark.parametrize(
    ("column", "named"),
    [
        ("ay", "ay: expected left positive"),
        ("yaw_rate", "yaw_rate: expected left positive"),
        ("steering_wheel_angle", "steering_wheel_angle: expected left positive"),
    ],
)
def test_one_lateral_sign_flipped_on_a_straight_drive_is_named(column, named):
    # The real log varies too little for the scale checks (yaw rate sd ~0.004 rad/s, ay ~0.08
    # m/s²); its yaw rate, steering and ay still agree in sign (correlations +0.89 and +0.65
    # after the z-down frame is turned), so the one flipped channel is the odd one out.
    message = _error(REAL.assign(**{column: -REAL[column]}), RAV4)
    assert message.startswith(named)
    assert "with the steering's V·δ/(i·L)" in message and "of ay with V·yaw_rate" in message


@pytest.mark.parametrize("source", ["real", "synthetic"])
def test_time_in_milliseconds(source):
    df, vehicle = (REAL, RAV4) if source == "real" else (_synthetic(), COMPACT)
    message = _error(df.assign(time=df["time"] * 1000.0), vehicle)
    assert message.startswith("time: expected seconds")
    assert "time looks like milliseconds" in message


def test_real_slow_log_is_not_read_as_milliseconds():
    # Genuine 1 Hz data of a car that accelerates: the speed changes by a·dt per sample.
    df = _synthetic(duration_s=600.0, rate_hz=1.0)
    stream = validate_stream(df, COMPACT)
    assert any(flag.startswith("sample rate 1 Hz") for flag in stream.flags)


def test_more_than_ten_hours_below_one_hertz():
    df = _synthetic(duration_s=120.0, rate_hz=1.0)
    df["time"] *= 400.0  # 119 intervals of 400 s: 13.2 h
    assert "13.2 h drive" in _error(df)


def test_steering_in_degrees_on_a_straight_drive():
    df = REAL.assign(steering_wheel_angle=np.degrees(REAL["steering_wheel_angle"]))
    assert df["steering_wheel_angle"].abs().max() < 12.6  # inside the rad range
    message = _error(df, RAV4)
    assert message.startswith(
        "steering_wheel_angle: expected rad, got values that look like degrees"
    )


def test_steering_offset_in_rad_is_not_degrees():
    # A misaligned steering wheel (5°) on a straight drive: the median is removed first.
    df = REAL.assign(steering_wheel_angle=REAL["steering_wheel_angle"] + np.radians(5.0))
    assert validate_stream(df, RAV4).flags == ()


def test_long_gap_is_flagged():
    df = _synthetic()
    df.loc[df["time"] >= 15.0, "time"] += 600.0
    stream = validate_stream(df, COMPACT)
    assert stream.gaps and stream.gaps[0][1] - stream.gaps[0][0] > 599.0
    (flag,) = stream.flags
    assert "longest 600.0 s at 15.0 s" in flag


def test_short_gap_is_not_flagged():
    df = _synthetic()
    df.loc[df["time"] >= 15.0, "time"] += 2.0
    stream = validate_stream(df, COMPACT)
    assert len(stream.gaps) == 1 and stream.flags == ()


def test_half_the_samples_dropped_is_flagged_with_the_fraction():
    df = _synthetic()
    rows = np.random.default_rng(1).random(len(df)) < 0.5
    df.loc[rows, df.columns[1:]] = np.nan
    (flag,) = validate_stream(df, COMPACT).flags
    fraction = float(flag.split("% of the samples dropped")[0].rsplit(" ", 1)[1])
    assert fraction == pytest.approx(100 * rows.mean(), abs=5)


def test_few_dropped_samples_are_not_flagged():
    assert validate_stream(_synthetic(drop_fraction=0.05), COMPACT).flags == ()


def test_low_rate_is_flagged():
    (flag,) = validate_stream(_synthetic(rate_hz=10.0, duration_s=60.0), COMPACT).flags
    assert flag.startswith("sample rate 10 Hz: expected >= 20 Hz; slip windows")


def test_dropped_fraction_of_regular_jittery_and_slow_channels():
    t = np.arange(1000) * 0.01
    assert dropped_fraction(t) == pytest.approx(0.0, abs=1e-9)
    assert dropped_fraction(t[::5]) == pytest.approx(0.0, abs=1e-9)  # a slower channel
    keep = np.random.default_rng(0).random(t.size) > 0.3
    assert dropped_fraction(t[keep]) == pytest.approx(0.3, abs=0.05)
    # The real log's CAN timing jitters by ±40 % (and may drop a frame): ~10 %, under the flag.
    assert dropped_fraction(REAL["time"].to_numpy()) < 0.75 * DROPPED_FLAG_FRACTION
    # A long gap is a gap, not dropped samples.
    assert dropped_fraction(np.concatenate([t, t + 100.0])) == pytest.approx(0.0, abs=1e-9)


def test_sampling_flags_order_and_thresholds():
    assert sampling_flags(20.0, ((0.0, LONG_GAP_S - 0.1),), {"ax": 0.2}) == []
    flags = sampling_flags(5.0, ((0.0, 30.0), (40.0, 52.0)), {"ax": 0.1, "ay": 0.4})
    assert [f.split(" ")[0] for f in flags] == ["sample", "2", "ay:"]


def test_inspect_prints_flags(tmp_path, capsys):
    path = tmp_path / "slow.csv"
    write_stream(_synthetic(rate_hz=10.0, duration_s=60.0), path)
    assert main(["inspect", str(path), "--vehicle", "compact_fwd"]) == 0
    assert "flag: sample rate 10 Hz" in capsys.readouterr().out


# --- property: a corruption that changes the answer is an error or a flag ---------------------

_FUZZ_BASE = _synthetic(duration_s=40.0)


def _fuzz(df: pd.DataFrame, how: tuple) -> tuple[pd.DataFrame, str]:
    """Apply one corruption; return the table and what must catch it: 'error' or 'flag'."""
    df = df.copy()
    damage = how[0]
    if damage == "sign":
        df[list(how[1])] = -df[list(how[1])]
        return df, "error"
    if damage == "time_scale":
        df["time"] = df["time"] * how[1]
        return df, "error"
    if damage == "steer_deg":
        # Gentle or straight drives keep degrees inside the rad range: the hard case.
        df[["ay", "yaw_rate", "steering_wheel_angle"]] *= how[1]
        df["steering_wheel_angle"] = np.degrees(df["steering_wheel_angle"])
        return df, "error"
    if damage == "gap":
        start, length = how[1], how[2]
        df.loc[df["time"] >= start, "time"] += length
        return df, "flag" if length >= 10.0 else "none"
    if damage == "nan_rows":
        rows = np.random.default_rng(how[2]).random(len(df)) < how[1]
        df.loc[rows, df.columns[1:]] = np.nan
        return df, "flag" if how[1] >= 0.35 else "none"
    step = how[1]  # decimate: a slower logger
    return df.iloc[::step].reset_index(drop=True), "flag" if 50.0 / step < 20.0 else "none"


fuzz_case = st.one_of(
    st.tuples(st.just("sign"), st.sampled_from([("ax",), ("ay",), ("ax", "ay")])),
    st.tuples(st.just("time_scale"), st.sampled_from([1000.0, 1e6])),
    st.tuples(st.just("steer_deg"), st.sampled_from([1.0, 0.5, 0.2])),
    st.tuples(st.just("gap"), st.floats(5.0, 30.0), st.sampled_from([2.0, 15.0, 600.0])),
    st.tuples(st.just("nan_rows"), st.sampled_from([0.05, 0.4, 0.6]), st.integers(0, 9)),
    st.tuples(st.just("decimate"), st.sampled_from([2, 3, 5])),
)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(fuzz_case)
def test_fuzz_corruption_is_an_error_or_a_flag(how):
    df, expect = _fuzz(_FUZZ_BASE, how)
    try:
        stream = validate_stream(df, COMPACT)
    except BadInputError as err:
        assert "\n" not in str(err)
        assert expect == "error", f"{how}: unexpected error {err}"
        return
    assert expect != "error", f"{how}: accepted silently"
    assert bool(stream.flags) == (expect == "flag"), f"{how}: flags {stream.flags}"


def test_dropped_fraction_of_a_long_log_reads_its_period_from_runs_of_intervals(monkeypatch):
    """A 10 h log at 100 Hz whose CAN timing alternates 9 and 11 ms: nothing dropped, though
    every 180th interval (a stride to the 20,000 of :mod:`~tyrebayes.streams.log_sample`) is
    9 ms. On a log with random jitter and a fifth of its samples dropped at random, what the
    period from every interval gives."""
    import tyrebayes.streams.plausibility as plausibility

    steps = np.tile([0.009, 0.011], 1_800_000)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    assert dropped_fraction(t) == pytest.approx(0.0, abs=1e-3)
    rng = np.random.default_rng(2)
    t = np.cumsum(0.01 + rng.normal(0.0, 5e-4, 3_600_000))
    kept = t[rng.random(t.size) > 0.2]
    sampled = dropped_fraction(kept)
    monkeypatch.setattr(plausibility, "sample_runs", lambda x: x[None, :])  # every interval
    assert sampled == pytest.approx(dropped_fraction(kept), abs=0.005)
    assert sampled == pytest.approx(0.2, abs=0.01)
