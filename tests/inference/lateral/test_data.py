"""Cornering observations: channels, selection, and the reasons a drive has no lateral fit."""

import numpy as np
import pandas as pd
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import NoCornering, cornering_observations
from tyrebayes.inference.lateral.data import MAX_LONGITUDINAL_MPS2, MIN_SPEED_MPS, RATE_HZ
from tyrebayes.simulate.cornering import simulate_cornering

VEHICLE = load_vehicle("compact_fwd")


def test_a_cornering_drive_is_decimated_and_masked():
    frame, _ = simulate_cornering(VEHICLE, duration_s=120.0, seed=3)
    obs = cornering_observations(frame, VEHICLE)
    assert obs.speed.shape == (int(120.0 * RATE_HZ),)
    assert obs.dt_s == pytest.approx(1.0 / RATE_HZ)
    assert not obs.road_wheel and float(obs.steering_ratio) == float(VEHICLE.steering_ratio)
    assert obs.cornering_seconds > 15.0
    # the kinematic equation's samples are a subset with two valid neighbours each side
    kin, mask = np.asarray(obs.mask_kinematic), np.asarray(obs.mask)
    assert np.all(mask[kin]) and not kin[:2].any() and not kin[-2:].any()


def test_slow_samples_are_left_out():
    frame, _ = simulate_cornering(VEHICLE, duration_s=120.0, seed=3)
    frame.loc[frame.index[:3000], [c for c in frame if c.startswith("wheel_speed")]] = 1.0 / float(
        VEHICLE.wheel_radius_m
    )
    obs = cornering_observations(frame, VEHICLE)
    assert not np.asarray(obs.mask)[: int(25 * RATE_HZ)].any()
    assert MIN_SPEED_MPS > 1.0


def test_braking_samples_are_left_out_and_counted():
    """A corner taken braking: the static axle loads the model normalises by no longer hold,
    so those samples enter neither equation, and they are counted apart."""
    t = np.arange(0.0, 60.0, 0.01)
    # 20 m/s, then 2 m/s² of braking from 20 s to 25 s, then 10 m/s; a steady 3 m/s² corner.
    speed = np.interp(t, [0.0, 20.0, 25.0, 60.0], [20.0, 20.0, 10.0, 10.0])
    frame = pd.DataFrame(
        {"time": t, "yaw_rate": 3.0 / speed, "ay": 3.0 + 0 * t, "speed_reference": speed,
         "steering_wheel_angle": 0.5 + 0 * t}
    )  # fmt: skip
    obs = cornering_observations(frame, VEHICLE)
    braking = np.asarray(obs.longitudinal)
    mask, kin = np.asarray(obs.mask), np.asarray(obs.mask_kinematic)
    during = slice(int(21 * RATE_HZ), int(24 * RATE_HZ))
    assert braking[during].all() and not mask[during].any() and not kin[during].any()
    assert (
        not braking[: int(19 * RATE_HZ)].any() and mask[int(5 * RATE_HZ) : int(19 * RATE_HZ)].all()
    )
    assert not (braking & mask).any() and MAX_LONGITUDINAL_MPS2 < 2.0
    # the signals of a braking sample are kept (the kinematic derivative's neighbours)
    assert np.asarray(obs.speed)[during] == pytest.approx(speed[::10][during], abs=0.2)


def test_a_straight_drive_has_no_cornering():
    frame, _ = simulate_cornering(VEHICLE, manoeuvre="straight", duration_s=120.0, seed=3)
    with pytest.raises(NoCornering, match="no usable cornering: 0.0 s"):
        cornering_observations(frame, VEHICLE)


def test_a_road_wheel_angle_log_needs_no_wheel_speeds():
    frame, truth = simulate_cornering(VEHICLE, duration_s=120.0, seed=3)
    log = pd.DataFrame(
        {
            "time": frame["time"],
            "yaw_rate": frame["yaw_rate"],
            "ay": frame["ay"],
            "speed_reference": frame["wheel_speed_rl"] * float(VEHICLE.wheel_radius_m),
            "wheel_angle_front": frame["steering_wheel_angle"] / truth.steering_ratio,
        }
    )
    assert cornering_observations(log, VEHICLE).road_wheel


@pytest.mark.parametrize(
    ("drop", "message"),
    [
        (["yaw_rate"], "expected a yaw_rate column"),
        (["steering_wheel_angle"], "steering_wheel_angle or wheel_angle_front"),
        (["wheel_speed_rl", "wheel_speed_rr"], "wheel speeds or a speed_reference"),
    ],
)
def test_missing_channels_are_named(drop, message):
    frame, _ = simulate_cornering(VEHICLE, duration_s=30.0, seed=3)
    with pytest.raises(NoCornering, match=message):
        cornering_observations(frame.drop(columns=drop), VEHICLE)


def test_time_must_increase():
    frame, _ = simulate_cornering(VEHICLE, duration_s=30.0, seed=3)
    frame.loc[10, "time"] = frame.loc[5, "time"]
    with pytest.raises(NoCornering, match="strictly increasing"):
        cornering_observations(frame, VEHICLE)


def test_turning_at_walking_pace_is_not_identified():
    frame, _ = simulate_cornering(VEHICLE, duration_s=120.0, seed=3)
    slow = frame.copy()
    wheels = [c for c in frame if c.startswith("wheel_speed")]
    slow[wheels] = frame[wheels] * 0.25  # 2-8 m/s: the same steering, a quarter of the speed
    slow["ay"] = frame["ay"] * 0.25**2 * 8  # tight turns: a_y above 1 m/s² below 8 m/s
    with pytest.raises(NoCornering, match="not identified"):
        cornering_observations(slow, VEHICLE)


def test_samples_next_to_a_gap_are_left_out():
    """A NaN in the yaw rate spoils its neighbours' yaw acceleration: no NaN reaches the masks."""
    frame, _ = simulate_cornering(VEHICLE, duration_s=120.0, seed=3)
    frame.loc[frame.index[::997], "yaw_rate"] = np.nan
    obs = cornering_observations(frame, VEHICLE)
    mask = np.asarray(obs.mask)
    for name in ("speed", "yaw_rate", "yaw_acceleration", "ay", "steering"):
        assert np.all(np.isfinite(np.asarray(getattr(obs, name)))), name
    assert mask.sum() < mask.size
