"""A tyre set's lateral estimate in a fleet run (tyrebayes.batch.lateral)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.batch.lateral import (
    DRIVE_LATERAL_COLUMNS,
    SET_LATERAL_COLUMNS,
    combine_drive_laterals,
    drive_lateral,
    lateral_off,
)
from tyrebayes.batch.settings import RunSettings
from tyrebayes.inference.lateral import LateralPriors

VEHICLE = load_vehicle("compact_fwd")


def _drive(c_y, log_sd):
    return {"c_y": c_y, "c_y_log_sd": log_sd, "lateral_reason": ""}


def test_drives_combine_as_gaussians_in_log_c_y_with_the_prior_counted_once():
    s0 = LateralPriors().c_y_log_sd / math.sqrt(2)
    m0 = math.log(LateralPriors().c_y_median)
    drives = [_drive(14.0, 0.10), _drive(15.0, 0.20), _drive(float("nan"), float("nan"))]
    out = combine_drive_laterals(drives)
    assert set(out) == set(SET_LATERAL_COLUMNS)
    prec = 1 / 0.1**2 + 1 / 0.2**2 - 1 / s0**2
    mean = (math.log(14) / 0.1**2 + math.log(15) / 0.2**2 - m0 / s0**2) / prec
    assert out["c_y_drives"] == 2 and out["lateral_reason"] == ""
    assert math.isclose(out["c_y"], math.exp(mean), rel_tol=1e-12)
    assert math.isclose(out["c_y_log_sd"], prec**-0.5, rel_tol=1e-12)
    assert math.isclose(out["c_y_sd"], out["c_y"] * out["c_y_log_sd"])
    # one drive is its own posterior
    one = combine_drive_laterals([_drive(14.0, 0.1)])
    assert math.isclose(one["c_y"], 14.0) and math.isclose(one["c_y_log_sd"], 0.1)


def test_a_set_without_cornering_says_why():
    out = combine_drive_laterals(
        [lateral_off(), {"lateral_reason": "lateral: no usable cornering: 3 s"}]
    )
    assert out["c_y_drives"] == 0 and np.isnan(out["c_y"]) and np.isnan(out["c_y_sd"])
    assert out["lateral_reason"].startswith("none of 2 drive(s) gave c_y (first: lateral: not")
    assert "none of 0 drive(s)" in combine_drive_laterals([])["lateral_reason"]
    # a skipped drive's record comes back from JSON: null where it had no estimate
    back = combine_drive_laterals([{"c_y": None, "c_y_log_sd": None, "lateral_reason": "x"}])
    assert back["c_y_drives"] == 0 and "(first: x)" in back["lateral_reason"]
    mixed = combine_drive_laterals([{"c_y": None, "c_y_log_sd": None}, _drive(14.0, 0.1)])
    assert mixed["c_y_drives"] == 1 and math.isclose(mixed["c_y"], 14.0)


def test_straight_drive_has_no_lateral_estimate_and_costs_no_fit():
    t = np.arange(0, 60, 0.01)
    frame = pd.DataFrame(
        {
            "time": t,
            "yaw_rate": 0 * t,
            "ay": 0 * t,
            "speed_reference": 20 + 0 * t,
            "steering_wheel_angle": 0 * t,
        }
    )
    out = drive_lateral(frame, VEHICLE, "snow")
    assert set(out) == set(DRIVE_LATERAL_COLUMNS)
    assert np.isnan(out["c_y"]) and "no usable cornering" in out["lateral_reason"]


def test_lateral_fits_are_part_of_the_drive_settings():
    on, off = RunSettings(), RunSettings(lateral=False)
    assert on.drive_settings()["lateral"] is True and off.drive_settings()["lateral"] is False
    # the seed reaches the drives only through the lateral fit's draws; the fit's method too
    assert RunSettings(seed=1).drive_settings() != on.drive_settings()
    assert on.drive_settings()["lateral_method"] == "moments"
    assert RunSettings(method="nuts").drive_settings()["lateral_method"] == "laplace"
    assert RunSettings(lateral=False, seed=1).drive_settings() == off.drive_settings()


@pytest.mark.slow
def test_cornering_drive_gives_its_geometric_mean_c_y():
    from tyrebayes.simulate.cornering import simulate_cornering

    frame, truth = simulate_cornering(VEHICLE, manoeuvre="mixed", duration_s=180.0, seed=0,
                                      c_y_front=12.0, c_y_rear=15.0)  # fmt: skip
    out = drive_lateral(frame, VEHICLE, "dry", seed=0)
    assert out["lateral_reason"] == "", out
    c = math.sqrt(12.0 * 15.0)
    assert abs(math.log(out["c_y"] / c)) < max(3 * out["c_y_log_sd"], 0.02)
    assert abs(out["c_y_front"] / 12.0 - 1) < 0.05 and abs(out["c_y_rear"] / 15.0 - 1) < 0.05


def test_the_moments_fit_agrees_with_the_batch_fit():
    """A fast run's lateral fit (the in-car estimator over the drive) against the batch fit:
    stated tolerance, the geometric mean c_y within two batch log-sds; the log-sd no narrower
    than the batch fit's over 1.5 and no wider than twice it (on three minutes the moments' VIF
    is still blended with its cautious start, and they leave out the samples near the curve's
    peak)."""
    from tyrebayes.simulate.cornering import simulate_cornering
    from tyrebayes.streams import validate_stream

    # Three minutes: less than the 4 minutes of 30 s batches a car waits for; a drive's fit does
    # not wait (the batch fit's rule).
    frame, _ = simulate_cornering(VEHICLE, manoeuvre="mixed", duration_s=180.0, seed=3)
    data = validate_stream(frame, VEHICLE).data
    batch = drive_lateral(data, VEHICLE, "dry")
    fast = drive_lateral(data, VEHICLE, "dry", method="moments")
    assert batch["lateral_reason"] == "" and fast["lateral_reason"] == "", fast
    assert abs(math.log(fast["c_y"] / batch["c_y"])) < 2 * batch["c_y_log_sd"]
    assert 1 / 1.5 < fast["c_y_log_sd"] / batch["c_y_log_sd"] < 2.0
    with pytest.raises(ValueError, match="method: expected one of"):
        drive_lateral(data, VEHICLE, "dry", method="ols")


def test_the_sets_axles_keep_the_drives_split_around_the_combined_level():
    from tyrebayes.batch.lateral import combined_cornering

    drives = [
        {"c_y": 20.0, "c_y_log_sd": 0.1, "c_y_front": 16.0, "c_y_rear": 25.0, "lateral_reason": ""},
        {"c_y": 22.0, "c_y_log_sd": 0.2, "c_y_front": 19.0, "c_y_rear": 25.5, "lateral_reason": ""},
        {"c_y": None, "c_y_log_sd": None, "lateral_reason": "lateral: no usable cornering"},
    ]
    level = combine_drive_laterals(drives)
    c = combined_cornering(drives)
    assert c.source == "drive_lateral"
    assert np.sqrt(c.front_per_rad * c.rear_per_rad) == pytest.approx(level["c_y"])
    w = np.array([1 / 0.1**2, 1 / 0.2**2])
    split = np.sum(w * np.log([16.0 / 25.0, 19.0 / 25.5])) / w.sum()
    assert c.front_per_rad / c.rear_per_rad == pytest.approx(np.exp(split))
    assert c.log_sd > level["c_y_log_sd"]  # the split's scatter adds to the level's
    assert combined_cornering(drives[2:]) is None
