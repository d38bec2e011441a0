"""A short simulated RAV4 drive and its frames, encoded by cantools with the shipped DBC."""

from __future__ import annotations

import pandas as pd
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.simulate.can_log import stream_messages
from tyrebayes.streams.can import load_dbc, load_profile
from tyrebayes.streams.synthetic import synthetic_stream

#: A logged epoch time, as candump and BLF write (2023-11-14).
EPOCH_S = 1_700_000_000.0


@pytest.fixture(scope="session")
def rav4():
    return load_vehicle("suv_rav4")


@pytest.fixture(scope="session")
def profile():
    return load_profile("toyota_rav4_2017")


@pytest.fixture(scope="session")
def db(profile):
    return load_dbc(profile.dbc_path())


@pytest.fixture(scope="session")
def drive(rav4) -> pd.DataFrame:
    df, _ = synthetic_stream(rav4, duration_s=8.0, rate_hz=50.0, seed=3)
    return df


@pytest.fixture(scope="session")
def messages(drive, profile, db, rav4) -> list:
    return stream_messages(drive, profile, db, wheel_radius_m=rav4.wheel_radius_m, start_s=EPOCH_S)
