"""The real RAV4 segment (comma2k19) as the car's bus would carry it, back through the profile.

The segment's CSV (decoded from this car's bus) is encoded back into WHEEL_SPEEDS, KINEMATICS,
STEER_ANGLE_SENSOR and SPEED frames with the shipped DBC, written as a candump log at the CSV's
own (irregular, ~89 Hz) timestamps, and converted. The CSV's wheel speeds are CAN values (0.01 km/h
steps) divided by 0.35 m and printed to 1e-6 rad/s, so the round trip must give them back to
1e-6 m/s. Its IMU is the dashcam's, z down: ay and yaw_rate are turned to ISO 8855 first, as the
car's KINEMATICS carry them once decoded. The segment's own raw CAN is tested in
``test_comma_rav4.py``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from tyrebayes._resources import data_dir
from tyrebayes.simulate.can_log import stream_messages, write_can_log
from tyrebayes.streams import validate_stream
from tyrebayes.streams.can import read_can_log
from tyrebayes.streams.schema import WHEEL_COLUMNS

# The copy the package ships (its provenance: tyrebayes/data/README.md).
REAL = data_dir() / "comma2k19_rav4_segment.csv"
# The nominal radius the CSV's authors divided by (tyrebayes/data/README.md), = suv_rav4's.
RADIUS_M = 0.35


def test_rav4_segment_wheel_speeds_to_a_micrometre_per_second(profile, db, rav4, tmp_path):
    assert rav4.wheel_radius_m == RADIUS_M
    csv = pd.read_csv(REAL)
    iso = csv.assign(ay=-csv["ay"], yaw_rate=-csv["yaw_rate"])  # dashcam z down -> ISO 8855
    msgs = stream_messages(iso, profile, db, wheel_radius_m=RADIUS_M, start_s=1533198887.0)
    path = write_can_log(msgs, tmp_path / "rav4.log")
    conv = read_can_log(path, profile)
    assert conv.data.shape[0] == len(csv)
    for column in WHEEL_COLUMNS:
        err_mps = np.abs(conv.data[column].to_numpy() - csv[column].to_numpy()) * RADIUS_M
        assert err_mps.max() <= 1e-6, column
    # The irregular time stamps go through the stream pipeline's resampling.
    stream = validate_stream(conv.data, rav4)
    assert stream.duration_s == pytest.approx(csv["time"].iloc[-1], abs=0.05)
