"""Car profiles: the shipped RAV4 profile, unit conversion factors, and errors in profile files."""

from __future__ import annotations

import math

import pytest

from tyrebayes import BadInputError
from tyrebayes._resources import models_dir
from tyrebayes.streams.can import ProfileChannel, load_profile


def test_rav4_profile(profile, db):
    assert profile.vehicle == "suv_rav4"
    # The package ships its DBC: never the reference-data folder.
    assert profile.dbc_path() == models_dir() / "dbc" / "toyota_new_mc_pt.dbc"
    assert {ch.column for ch in profile.channels} >= {
        "wheel_speed_fl",
        "wheel_speed_fr",
        "wheel_speed_rl",
        "wheel_speed_rr",
        "ax",
        "ay",
        "yaw_rate",
        "steering_wheel_angle",
    }
    ids = {db.get_message_by_name(ch.message).frame_id for ch in profile.channels}
    assert ids == {0xAA, 0x24, 0x25, 0xB4}


def test_unit_factors(profile):
    # 36 km/h = 10 m/s on a 0.35 m wheel = 28.57 rad/s.
    assert 36.0 * profile.channel("wheel_speed_fl").factor(0.35) == pytest.approx(10.0 / 0.35)
    assert profile.channel("yaw_rate").factor(0.35) == pytest.approx(math.pi / 180.0)
    assert profile.channel("speed_reference").factor(0.35) == pytest.approx(1.0 / 3.6)
    g = ProfileChannel("ax", "M", ("A",), "g", sign=-1.0)
    assert g.factor(0.3) == pytest.approx(-9.80665)


@pytest.mark.parametrize(
    ("body", "match"),
    [
        ('vehicle = "suv_rav4"\ndbc = "x.dbc"\n', "missing key 'channels'"),
        ('vehicle = "v"\ndbc = "x.dbc"\ncolour = 1\n[channels.ax]\n', "got unknown"),
        (
            'vehicle = "v"\ndbc = "x.dbc"\n[channels.ax]\nmessage = "M"\nsignals = ["S"]\n'
            'unit = "furlong"\n',
            "expected a unit in",
        ),
        (
            'vehicle = "v"\ndbc = "x.dbc"\n[channels.ax]\nmessage = "M"\nsignals = ["S"]\n'
            'unit = "deg"\n',
            "expected a unit of acceleration",
        ),
        (
            'vehicle = "v"\ndbc = "x.dbc"\n[channels.tyre_colour]\nmessage = "M"\n'
            'signals = ["S"]\nunit = "deg"\n',
            "expected a stream column",
        ),
        (
            'vehicle = "v"\ndbc = "x.dbc"\n[channels.ax]\nmessage = "M"\nsignals = ["S"]\n'
            'unit = "g"\nsign = 2\n',
            "expected sign 1 or -1",
        ),
        ('vehicle = "v"\ndbc = "x.dbc"\n[channels.ax]\nsignals = ["S"]\n', "missing key 'message'"),
        ("not toml [", "not valid TOML"),
    ],
)
def test_bad_profile_files(tmp_path, body, match):
    path = tmp_path / "car.toml"
    path.write_text(body)
    with pytest.raises(BadInputError, match=match):
        load_profile(path)


def test_unknown_profile_and_missing_dbc(tmp_path):
    with pytest.raises(BadInputError, match=r"one of \['toyota_rav4_2017'"):
        load_profile("no_such_car")
    path = tmp_path / "car.toml"
    path.write_text(
        'vehicle = "suv_rav4"\ndbc = "nowhere.dbc"\n[channels.ax]\nmessage = "M"\n'
        'signals = ["S"]\nunit = "m/s^2"\n'
    )
    with pytest.raises(BadInputError, match="expected its DBC 'nowhere.dbc'"):
        load_profile(path).dbc_path()
    # A DBC beside the profile is found there.
    (tmp_path / "nowhere.dbc").write_text("")
    assert load_profile(path).dbc_path() == tmp_path / "nowhere.dbc"
