"""Validation: every error with a file that triggers it, non-fatal gaps, resampling, corruption."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from tyrebayes import BadInputError
from tyrebayes._domain import load_vehicle
from tyrebayes._resources import data_dir
from tyrebayes.streams import (
    REQUIRED_COLUMNS,
    compute_features,
    read_stream,
    validate_stream,
    write_stream,
)
from tyrebayes.streams.schema import WHEEL_COLUMNS
from tyrebayes.streams.synthetic import synthetic_stream

VEHICLE = load_vehicle("compact_fwd")
R = VEHICLE.wheel_radius_m


def _clean(seed: int = 0, **kwargs) -> pd.DataFrame:
    kwargs.setdefault("duration_s", 30.0)
    kwargs.setdefault("rate_hz", 50.0)
    df, _ = synthetic_stream(VEHICLE, seed=seed, **kwargs)
    return df


def _through_file(df: pd.DataFrame, tmp_path, suffix: str = ".csv"):
    path = tmp_path / f"stream{suffix}"
    write_stream(df, path)
    return validate_stream(read_stream(path), VEHICLE)


def _expect(df: pd.DataFrame, tmp_path, match: str, suffix: str = ".csv") -> None:
    with pytest.raises(BadInputError, match=match) as info:
        _through_file(df, tmp_path, suffix)
    assert "\n" not in str(info.value)  # one line for the CLI


def test_clean_file_passes(tmp_path):
    stream = _through_file(_clean(), tmp_path)
    assert stream.sample_rate_hz == pytest.approx(50.0)
    assert not stream.resampled
    assert stream.gaps == ()
    assert stream.quantisation["wheel_speed_fl"] == pytest.approx(0.01 / 3.6 / R, rel=1e-6)


def test_missing_required_column(tmp_path):
    _expect(
        _clean().drop(columns=["yaw_rate"]), tmp_path, r"missing required columns \['yaw_rate'\]"
    )


def test_text_in_numeric_column(tmp_path):
    df = _clean().astype({"ax": object})
    df.loc[10, "ax"] = "n/a?"
    _expect(df, tmp_path, "column 'ax': expected numbers")


def test_duplicated_time(tmp_path):
    df = _clean()
    df.loc[100, "time"] = df.loc[99, "time"]
    _expect(df, tmp_path, "duplicated time")


def test_non_monotonic_time(tmp_path):
    df = _clean()
    df.loc[[100, 101], "time"] = df.loc[[101, 100], "time"].to_numpy()
    _expect(df, tmp_path, "non-monotonic")


def test_missing_time_value(tmp_path):
    df = _clean()
    df.loc[5, "time"] = np.nan
    _expect(df, tmp_path, "time: expected a finite value")


def test_too_few_rows(tmp_path):
    _expect(_clean().iloc[:40], tmp_path, "too few samples: expected at least 100 rows, got 40")


def test_too_few_rows_with_wheel_speeds(tmp_path):
    df = _clean()
    df.loc[60:, "wheel_speed_rl"] = np.nan
    _expect(df, tmp_path, "expected at least 100 values of each wheel speed, got 60")


def test_all_nan_channel(tmp_path):
    df = _clean()
    df["ay"] = np.nan
    _expect(df, tmp_path, "column 'ay': expected measured values, got only NaN")


def test_constant_channel(tmp_path):
    df = _clean()
    df["steering_wheel_angle"] = 0.0
    _expect(df, tmp_path, "column 'steering_wheel_angle': expected a varying signal")


def test_constant_steering_on_a_straight_drive_is_not_an_error(tmp_path):
    df = _clean()
    df[["ay", "yaw_rate"]] *= 0.05  # a straight road: yaw within ±0.003 rad/s
    df["steering_wheel_angle"] = 0.0  # and a coarse steering signal on one step
    stream = _through_file(df, tmp_path)
    assert any("constant" in note for note in stream.notes)


def test_wheel_speeds_in_kmh_caught_by_reference(tmp_path):
    df = _clean()
    df[list(WHEEL_COLUMNS)] *= 3.6 * R  # ω [rad/s] · R [m] · 3.6 = km/h
    _expect(df, tmp_path, "look like km/h")


def test_wheel_speeds_in_mps_caught_by_reference(tmp_path):
    df = _clean()
    df[list(WHEEL_COLUMNS)] *= R
    _expect(df, tmp_path, "look like m/s")


def test_wheel_speeds_in_mps_caught_by_imu(tmp_path):
    df = _clean(speed_reference=False)
    df[list(WHEEL_COLUMNS)] *= R
    _expect(df, tmp_path, "wheel speeds in m/s")


def test_wheel_speeds_in_rpm(tmp_path):
    df = _clean()
    df[list(WHEEL_COLUMNS)] *= 60 / (2 * np.pi)
    _expect(df, tmp_path, "looks like rpm")


def test_one_wheel_off_scale(tmp_path):
    df = _clean()
    df["wheel_speed_fr"] *= 1.1
    _expect(df, tmp_path, "wheel_speed_fr: expected within 5% of the other wheels")


def test_steering_in_degrees_small(tmp_path):
    # ±11° of steering-wheel angle fits the rad range; the yaw-rate comparison catches it.
    df = _clean()
    df[["ay", "yaw_rate", "steering_wheel_angle"]] *= 0.5  # a gentler drive, still consistent
    df["steering_wheel_angle"] = np.degrees(df["steering_wheel_angle"])
    assert df["steering_wheel_angle"].abs().max() < 12.6
    _expect(df, tmp_path, "steering_wheel_angle: expected rad, got values that look like degrees")


def test_steering_in_degrees_large(tmp_path):
    df = _clean()
    df["steering_wheel_angle"] = np.degrees(df["steering_wheel_angle"]) * 3
    _expect(df, tmp_path, "looks like degrees")


def test_yaw_rate_in_deg_per_s(tmp_path):
    df = _clean()
    df["yaw_rate"] = np.degrees(df["yaw_rate"])
    _expect(df, tmp_path, "deg/s")


def test_ax_in_g(tmp_path):
    df = _clean()
    df["ax"] /= 9.80665
    _expect(df, tmp_path, "ax in g")


def test_yaw_sign_opposite_to_steering(tmp_path):
    df = _clean().drop(columns=["az"])  # without az the frame cannot be identified
    df["yaw_rate"] = -df["yaw_rate"]
    df["ay"] = -df["ay"]
    _expect(df, tmp_path, "same sign convention")


def test_unknown_suffix_and_garbage(tmp_path):
    with pytest.raises(BadInputError, match="expected a suffix"):
        read_stream(tmp_path / "x.txt")
    bad = tmp_path / "x.parquet"
    bad.write_bytes(b"not parquet at all")
    with pytest.raises(BadInputError, match="cannot parse"):
        read_stream(bad)


def test_z_down_imu_is_turned_to_iso(tmp_path):
    df = _clean()
    down = df.copy()
    down[["ay", "yaw_rate", "az"]] *= -1
    iso = validate_stream(df, VEHICLE)
    flipped = validate_stream(down, VEHICLE)
    assert any("z-down" in n for n in flipped.notes) and not iso.notes
    np.testing.assert_array_equal(flipped.data["yaw_rate"], iso.data["yaw_rate"])


def test_dropped_samples_are_bridged_not_fatal(tmp_path):
    clean = validate_stream(_clean(), VEHICLE)
    stream = _through_file(_clean(drop_fraction=0.05), tmp_path, ".parquet")
    assert 0.0 < stream.filled.mean() < 0.3
    assert 0.0 < stream.nan_fraction["ax"] < 0.02
    assert stream.gaps == ()
    feats, ref = compute_features(stream, VEHICLE), compute_features(clean, VEHICLE)
    # One dropped 20 ms sample, bridged linearly, moves V_x by well under the 0.02 m/s
    # quantisation-and-noise level of the 0.2 s smoothed wheel speeds.
    assert np.nanmax(np.abs(feats.vx_mps - ref.vx_mps)) < 0.02


def test_infinite_values_are_dropped_samples_with_a_note(tmp_path):
    df = _clean()
    df.loc[df.index[100:102], "wheel_speed_rr"] = np.inf
    df.loc[df.index[200], "ax"] = -np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no arithmetic on inf anywhere on the way
        stream = _through_file(df, tmp_path, ".parquet")
    assert stream.nan_fraction["wheel_speed_rr"] == pytest.approx(2 / len(df))
    assert stream.nan_fraction["ax"] == pytest.approx(1 / len(df))
    assert "column 'wheel_speed_rr': 2 infinite values read as dropped samples" in stream.notes
    assert "column 'ax': 1 infinite values read as dropped samples" in stream.notes
    assert np.isfinite(stream.data["wheel_speed_rr"]).all()  # bridged like any dropped sample


def test_long_gap_stays_nan_and_is_reported(tmp_path):
    df = _clean()
    gap = (df["time"] >= 10.0) & (df["time"] < 11.0)
    df.loc[gap, list(WHEEL_COLUMNS)] = np.nan
    stream = _through_file(df, tmp_path)
    assert len(stream.gaps) == 1
    start, end = stream.gaps[0]
    assert start == pytest.approx(10.0) and end == pytest.approx(10.98)
    feats = compute_features(stream, VEHICLE)
    assert not feats.valid[gap.to_numpy()].any()
    assert feats.valid[~gap.to_numpy()].mean() > 0.99


def test_multi_rate_table_is_resampled(tmp_path):
    """Wheel speeds at 100 Hz, IMU at 50 Hz on other instants, GNSS at 10 Hz, merged by time."""
    fast = _clean(rate_hz=100.0)
    t = fast["time"].to_numpy()
    wheels = fast[["time", *WHEEL_COLUMNS]]
    imu = fast.iloc[::2][["time", "ax", "ay", "az", "yaw_rate", "steering_wheel_angle"]].copy()
    imu["time"] += 0.003  # another bus, another clock phase
    gnss = fast.iloc[::10][["time", "speed_reference"]].copy()
    gnss["time"] += 0.001
    merged = pd.concat([wheels, imu, gnss]).sort_values("time").reset_index(drop=True)
    stream = _through_file(merged, tmp_path)
    assert stream.resampled
    assert stream.sample_rate_hz == pytest.approx(100.0, rel=1e-6)
    assert stream.channel_rate_hz["speed_reference"] == pytest.approx(10.0, rel=0.01)
    assert stream.data.shape[0] == pytest.approx(t.size, abs=1)
    # Interpolated IMU differs from the 100 Hz original by its noise only (sd 0.2 m/s²).
    ax = stream.data["ax"].to_numpy()
    diff = ax - np.interp(stream.data["time"], t, fast["ax"])
    assert np.nanstd(diff) < 0.25
    assert np.isfinite(stream.data["speed_reference"]).mean() > 0.99


def test_real_log_passes():
    vehicle = load_vehicle("suv_rav4")
    stream = validate_stream(read_stream(data_dir() / "comma2k19_rav4_segment.csv"), vehicle)
    assert stream.duration_s == pytest.approx(60.0, abs=0.1)
    assert 85 < stream.sample_rate_hz < 95  # CAN wheel speeds at ~89 Hz, irregular
    assert stream.resampled
    # CAN resolution 0.01 km/h over the assumed 0.35 m radius.
    assert stream.quantisation["wheel_speed_rl"] == pytest.approx(0.01 / 3.6 / 0.35, rel=1e-3)
    assert any("z-down" in n for n in stream.notes)


# --- property: corruption never gives a silent wrong answer ------------------------------------

_BASE = _clean(seed=3)
_BASE_FEATURES = compute_features(validate_stream(_BASE, VEHICLE), VEHICLE)
_UNIT_FACTORS = {
    "kmh": (list(WHEEL_COLUMNS), 3.6 * R),
    "mps": (list(WHEEL_COLUMNS), R),
    "rpm": (list(WHEEL_COLUMNS), 60 / (2 * np.pi)),
    "steer_deg": (["steering_wheel_angle"], 180 / np.pi),
    "yaw_deg": (["yaw_rate"], 180 / np.pi),
    "ax_g": (["ax"], 1 / 9.80665),
    "ay_g": (["ay"], 1 / 9.80665),
    "one_wheel": (["wheel_speed_rl"], 1.08),
}

corruption = st.one_of(
    st.tuples(st.just("drop"), st.sampled_from([*REQUIRED_COLUMNS, "speed_reference", "az"])),
    st.tuples(st.just("shuffle"), st.integers(0, 1400), st.integers(2, 50)),
    st.tuples(st.just("scale"), st.sampled_from(sorted(_UNIT_FACTORS))),
    st.tuples(
        st.just("nan_burst"),
        st.sampled_from(list(_BASE.columns)),
        st.integers(0, 1490),
        st.integers(1, 200),
    ),
)


def _corrupt(df: pd.DataFrame, how: tuple) -> pd.DataFrame:
    df = df.copy()
    if how[0] == "drop":
        return df.drop(columns=[how[1]], errors="ignore")
    if "time" not in df:
        return df  # already fatally corrupted
    if how[0] == "shuffle":
        start, length = how[1], how[2]
        block = df["time"].iloc[start : start + length].to_numpy()
        df.loc[df.index[start : start + length], "time"] = block[::-1]
        return df
    if how[0] == "scale":
        cols, factor = _UNIT_FACTORS[how[1]]
        cols = [c for c in cols if c in df]
        df[cols] = df[cols] * factor
        return df
    col, start, length = how[1], how[2], how[3]
    if col not in df:
        return df
    df.loc[df.index[start : start + length], col] = np.nan
    return df


@settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(st.lists(corruption, min_size=1, max_size=3))
def test_corruption_is_caught_or_harmless(corruptions):
    if ("drop", "speed_reference") in corruptions:
        # km/h and rad/s differ by 3.6 R ~ 1.1 on a car wheel: only a speed reference tells them
        # apart (a documented limit of validate_stream), so km/h is not combined with its loss.
        corruptions = [c for c in corruptions if c != ("scale", "kmh")]
    df = _BASE
    for how in corruptions:
        df = _corrupt(df, how)
    try:
        feats = compute_features(validate_stream(df, VEHICLE), VEHICLE)
    except BadInputError as err:
        assert "\n" not in str(err)
        event("rejected")
        return
    event("accepted")
    # Not rejected: then the answer must agree with the clean file wherever it claims validity.
    ref = _BASE_FEATURES
    assert feats.time_s.shape == ref.time_s.shape
    both = feats.valid & ref.valid
    assert both.mean() > 0.5
    # V_x: 0.05 m/s covers smoothing windows truncated at NaN bursts (noise 0.02 m/s at 0.2 s).
    assert np.max(np.abs(feats.vx_mps[both] - ref.vx_mps[both])) < 0.05
    # ρ_x: 0.05 covers a burst-shifted IMU offset estimate and truncated windows, far below the
    # unit errors this test is about (factors of 1.6 and more).
    rho_ok = both & np.isfinite(feats.rho_driven) & np.isfinite(ref.rho_driven)
    assert np.median(np.abs(feats.rho_driven[rho_ok] - ref.rho_driven[rho_ok])) < 0.01
    assert np.max(np.abs(feats.rho_driven[rho_ok] - ref.rho_driven[rho_ok])) < 0.05
