"""The real RAV4 fitted from its own CAN bus agrees with the same minute's dashcam CSV.

Issue 54, item 4: the raw CAN of the shipped comma2k19 segment, decoded with the shipped
``toyota_rav4_2017`` profile (the car's own wheel speeds, KINEMATICS IMU and steering), and the
dashcam-IMU CSV of the same minute (``tyrebayes/data/comma2k19_rav4_segment.csv``) give
longitudinal fits whose 90 % intervals of C_x overlap, and the same lateral verdict: a straight
highway minute has no cornering to fit.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tyrebayes._resources import data_dir
from tyrebayes.cli import main

pytestmark = pytest.mark.early
RAW_CAN = (
    Path(__file__).resolve().parents[1] / "streams" / "data" / "comma2k19_rav4" / "raw_can.npz"
)


def _fit(capsys, *argv: str) -> dict:
    code = main(["fit-tyre", *argv, "--vehicle", "suv_rav4", "--method", "fast", "--json"])
    payload = json.loads(capsys.readouterr().out)
    assert code == 0, payload.get("diagnostics")
    return payload


def test_own_imu_and_dashcam_agree(capsys):
    can = _fit(capsys, str(RAW_CAN), "--profile", "toyota_rav4_2017")
    dashcam = _fit(capsys, str(data_dir() / "comma2k19_rav4_segment.csv"))
    (lo_a, hi_a), (lo_b, hi_b) = can["c_x"]["hdi_90"], dashcam["c_x"]["hdi_90"]
    assert lo_a <= hi_b and lo_b <= hi_a, (can["c_x"], dashcam["c_x"])
    for fit in (can, dashcam):
        assert fit["lateral"] is None
        assert fit["lateral_reason"].startswith("lateral: no usable cornering")
