"""File formats: CSV / Parquet / MDF4 round trips, channel maps, atomic writes."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tyrebayes import BadInputError
from tyrebayes._domain import load_vehicle
from tyrebayes.streams import read_stream, validate_stream, write_stream
from tyrebayes.streams.synthetic import synthetic_stream

VEHICLE = load_vehicle("compact_fwd")


@pytest.fixture(scope="module")
def stream_df() -> pd.DataFrame:
    df, _ = synthetic_stream(VEHICLE, duration_s=20.0, rate_hz=50.0, seed=7, drop_fraction=0.03)
    df["trip_id"] = "A1"  # an extra text column: kept by CSV/Parquet, ignored by the pipeline
    return df


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".mf4"])
def test_round_trip(stream_df, tmp_path, suffix):
    path = tmp_path / f"drive{suffix}"
    write_stream(stream_df, path)
    back = read_stream(path)
    numeric = [c for c in stream_df.columns if c != "trip_id"]
    assert set(numeric) <= set(back.columns)
    # CSV keeps 12 significant digits; Parquet and MDF4 are binary float64.
    rtol = 1e-11 if suffix == ".csv" else 0.0
    for col in numeric:
        np.testing.assert_allclose(back[col], stream_df[col], rtol=rtol, atol=0, err_msg=col)
    if suffix != ".mf4":
        assert (back["trip_id"] == "A1").all()
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary left behind


def test_mdf_channel_map_and_own_time_bases(tmp_path):
    """A logger file: vendor channel names, wheel speeds at 100 Hz, IMU at 50 Hz, GNSS at 10 Hz."""
    df, _ = synthetic_stream(VEHICLE, duration_s=20.0, rate_hz=100.0, seed=2)
    names = {
        "wheel_speed_fl": "WhlSpd_FL",
        "wheel_speed_fr": "WhlSpd_FR",
        "wheel_speed_rl": "WhlSpd_RL",
        "wheel_speed_rr": "WhlSpd_RR",
        "ax": "IMU_AccX",
        "ay": "IMU_AccY",
        "az": "IMU_AccZ",
        "yaw_rate": "IMU_YawRate",
        "steering_wheel_angle": "SAS_Angle",
        "speed_reference": "GNSS_Speed",
    }
    logger = df.rename(columns=names)
    # Lower-rate channels: NaN off their own instants (write_stream leaves NaN out of MDF).
    slow_imu = np.arange(len(df)) % 2 == 1
    logger.loc[slow_imu, ["IMU_AccX", "IMU_AccY", "IMU_AccZ", "IMU_YawRate"]] = np.nan
    logger.loc[np.arange(len(df)) % 10 != 0, "GNSS_Speed"] = np.nan
    path = tmp_path / "logger.mf4"
    write_stream(logger, path)

    with pytest.raises(BadInputError, match="expected MDF channels"):
        read_stream(path)  # vendor names without a map
    table = read_stream(path, channel_map={v: k for k, v in names.items()})
    stream = validate_stream(table, VEHICLE)
    assert stream.sample_rate_hz == pytest.approx(100.0)
    assert stream.channel_rate_hz["speed_reference"] == pytest.approx(10.0)
    assert stream.channel_rate_hz["ax"] == pytest.approx(50.0)
    # IMU bridged linearly between its 50 Hz samples: the midpoints differ from the 100 Hz
    # truth by the noise (0.2 m/s² sd) times ~1.2. Only the last instant, after the IMU's last
    # sample, is missing: no extrapolation.
    ax = stream.data["ax"].to_numpy()
    assert np.isfinite(ax[:-1]).all() and np.isnan(ax[-1])
    assert np.std(ax[:-1] - df["ax"].to_numpy()[:-1]) < 0.3


def test_csv_channel_map(tmp_path):
    df, _ = synthetic_stream(VEHICLE, duration_s=5.0, seed=1)
    path = tmp_path / "s.csv"
    write_stream(df.rename(columns={"ax": "acc_x"}), path)
    assert "ax" in read_stream(path, channel_map={"acc_x": "ax"}).columns


def test_failed_write_leaves_nothing(tmp_path):
    bad = pd.DataFrame({"time": [0.0, 1.0], "x": [1, "a"]})  # mixed types: Parquet refuses
    target = tmp_path / "out.parquet"
    with pytest.raises(Exception):  # noqa: B017 - pyarrow's own error type
        write_stream(bad, target)
    assert list(tmp_path.iterdir()) == []


def test_missing_file():
    with pytest.raises(BadInputError, match="expected a readable file"):
        read_stream("/nonexistent/drive.csv")


def test_mdf_wheels_on_their_own_instants(tmp_path):
    """Each wheel speed in its own CAN message: no instant carries all four wheels."""
    df, truth = synthetic_stream(VEHICLE, duration_s=20.0, rate_hz=100.0, seed=9)
    parts = []
    for k, col in enumerate(
        ["wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl", "wheel_speed_rr"]
    ):
        part = df[["time", col]].copy()
        part["time"] += 0.001 * (k + 1)  # message phase on the bus
        parts.append(part)
    others = df.drop(
        columns=["wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl", "wheel_speed_rr"]
    )
    merged = pd.concat([others, *parts]).sort_values("time").reset_index(drop=True)
    path = tmp_path / "bus.mf4"
    write_stream(merged, path)
    stream = validate_stream(read_stream(path), VEHICLE)
    assert stream.resampled
    assert stream.sample_rate_hz == pytest.approx(100.0)
    # Interpolated by ≤ 4 ms: within the 0.02 rad/s noise of the wheel speeds.
    fl = stream.data["wheel_speed_fl"].to_numpy()
    ref = np.interp(stream.data["time"], df["time"], df["wheel_speed_fl"])
    assert np.nanstd(fl - ref) < 0.03


def test_datetime_time_column(tmp_path):
    df, _ = synthetic_stream(VEHICLE, duration_s=5.0, seed=1)
    df["time"] = pd.Timestamp("2024-01-01T12:00:00") + pd.to_timedelta(df["time"], unit="s")
    path = tmp_path / "dt.parquet"
    write_stream(df, path)
    stream = validate_stream(read_stream(path), VEHICLE)
    assert stream.duration_s == pytest.approx(4.99)
    assert stream.sample_rate_hz == pytest.approx(100.0)
