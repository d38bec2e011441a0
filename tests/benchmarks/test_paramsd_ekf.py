"""The paramsd-style baseline EKF (benchmarks/paramsd_ekf.py) on a linear single-track drive.

The simulator below shares the filter's model (linear bicycle, stiffness = factor × openpilot's
nominal), so these tests check the code, not the model: the external drives do that.
"""

import json
import math

import numpy as np
import pytest
from scipy.linalg import expm

from benchmarks.paramsd_ekf import (
    GRAVITY_MPS2,
    ParamsdConfig,
    nominal_cornering_stiffness,
    run_paramsd,
)
from tyrebayes.physics.vehicle import Vehicle

VEHICLE = Vehicle(
    mass_kg=1500.0,
    wheelbase_m=2.7,
    cog_to_front_axle_m=1.1,
    cog_height_m=0.55,
    yaw_inertia_kgm2=2500.0,
    track_width_m=1.55,
    wheel_radius_m=0.31,
    drive="fwd",
    steering_ratio=15.0,
)
# Openpilot's numbers, but a stiffness factor that starts unknown (sd 0.5): with P_initial = Q
# (sd 0.0005) the factor moves by a few hundredths in ten minutes (test below).
WIDE = ParamsdConfig(initial_sd_stiffness=0.5)


def simulate(
    factor: float,
    duration_s: float,
    steer_amplitude_rad: float,
    *,
    steer_ratio: float = 15.0,
    offset_rad: float = 0.0,
    speed_mps: float = 20.0,
    dt: float = 0.01,
    seed: int = 0,
):
    """Linear single-track drive at constant speed, exact zero-order-hold discretisation.

    Steering-wheel angle: two sines (0.1 and 0.37 Hz), read by a sensor with ``offset_rad`` added
    (the wheel reads ``offset_rad`` when the car goes straight); yaw rate noise sd 0.005 rad/s,
    steering noise sd 0.002 rad. Returns time, speed, yaw rate, measured steering-wheel angle, a_y.
    """
    v = VEHICLE
    m, L, a, J = v.mass_kg, v.wheelbase_m, v.cog_to_front_axle_m, v.yaw_inertia_kgm2
    b = L - a
    cf0, cr0 = nominal_cornering_stiffness(m, L, a)
    cf, cr, u = factor * cf0, factor * cr0, speed_mps
    A = np.array(
        [
            [-(cf + cr) / (m * u), -(cf * a - cr * b) / (m * u) - u],
            [-(cf * a - cr * b) / (J * u), -(cf * a * a + cr * b * b) / (J * u)],
        ]
    )
    B = np.array([cf / m, cf * a / J])
    M = np.zeros((3, 3))
    M[:2, :2], M[:2, 2] = A, B
    E = expm(M * dt)
    t = np.arange(0.0, duration_s, dt)
    sa = steer_amplitude_rad * (
        np.sin(2 * np.pi * 0.1 * t) + 0.5 * np.sin(2 * np.pi * 0.37 * t + 1.0)
    )
    s = np.zeros(2)
    r = np.empty(t.size)
    ay = np.empty(t.size)
    for i in range(t.size):
        delta = sa[i] / steer_ratio
        r[i] = s[1]
        ay[i] = (A[0] @ s + B[0] * delta) + u * s[1]
        s = E[:2, :2] @ s + E[:2, 2] * delta
    rng = np.random.default_rng(seed)
    return (
        t,
        np.full(t.size, u),
        r + 0.005 * rng.standard_normal(t.size),
        sa + offset_rad + 0.002 * rng.standard_normal(t.size),
        ay + 0.05 * rng.standard_normal(t.size),
    )


def test_nominal_stiffness_is_openpilots_civic_scaling():
    # The reference car gives the reference stiffnesses (openpilot selfdrive/car/__init__.py).
    cf, cr = nominal_cornering_stiffness(1326.0 + 136.0, 2.70, 1.08)
    assert cf == pytest.approx(192150.0)
    assert cr == pytest.approx(202500.0)
    # Per unit static axle load the scaling leaves every car the same c_y: 22.3 and 35.3 /rad.
    for mass, L, lf in ((1320.0, 2.6, 1.02), (1890.0, 2.7, 1.16)):
        cf, cr = nominal_cornering_stiffness(mass, L, lf)
        assert cf / (mass * GRAVITY_MPS2 * (L - lf) / L) == pytest.approx(22.34, abs=0.01)
        assert cr / (mass * GRAVITY_MPS2 * lf / L) == pytest.approx(35.31, abs=0.01)


@pytest.mark.parametrize("factor", [0.6, 1.25])
def test_factor_converges_near_truth_with_sinusoidal_steering(factor):
    t, u, r, sa, _ = simulate(factor, 60.0, 0.5)
    res = run_paramsd(t, u, r, sa, VEHICLE, config=WIDE)
    # Tolerance: 5 %; the remaining bias is the filter's one Euler step per sample (car_kf) and
    # the steering ratio it learns beside the factor (measured at 60 s).
    assert res.final_stiffness_factor == pytest.approx(factor, rel=0.05)
    assert res.final_steer_ratio == pytest.approx(15.0, rel=0.02)
    assert res.active.all()
    assert res.c_y_front["mean"] == pytest.approx(res.nominal_c_y_front * factor, rel=0.05)


def test_a_y_observation_also_converges():
    t, u, r, sa, ay = simulate(0.7, 60.0, 0.5, seed=1)
    cfg = ParamsdConfig(initial_sd_stiffness=0.5, use_ay=True)
    res = run_paramsd(t, u, r, sa, VEHICLE, lateral_acceleration=ay, config=cfg)
    assert res.final_stiffness_factor == pytest.approx(0.7, rel=0.05)


def test_openpilot_defaults_learn_slowly_and_state_a_constant_sd():
    # P_initial = Q and the pseudo-observations of the factor (sd 0.5 at 20 Hz) hold its sd near
    # sqrt(0.05 s · (0.0005)² /s · 0.5²) ≈ 0.0075 whatever the data: the factor starts at 1 and
    # has moved only part of the way to 0.6 after a minute.
    t, u, r, sa, _ = simulate(0.6, 60.0, 0.5)
    res = run_paramsd(t, u, r, sa, VEHICLE)
    assert 0.6 < res.final_stiffness_factor < 0.995
    assert np.all(np.diff(res.stiffness_factor[1000:]) < 1e-3)  # moves one way, toward truth
    assert 0.003 < res.final_stiffness_factor_sd < 0.012


@pytest.mark.parametrize("config", [ParamsdConfig(), WIDE], ids=["openpilot", "wide"])
def test_no_steering_keeps_factor_at_prior(config):
    t, u, r, sa, _ = simulate(0.6, 40.0, 0.0)
    res = run_paramsd(t, u, r, sa, VEHICLE, config=config)
    # Straight driving says nothing about the stiffness: the factor stays at 1 and its sd does
    # not shrink below what the pseudo-observations alone leave.
    assert np.max(np.abs(res.stiffness_factor - 1.0)) < 2e-3
    assert res.final_angle_offset == pytest.approx(0.0, abs=1e-3)


def test_straight_drive_with_offset_learns_the_offset_not_the_factor():
    t, u, r, sa, _ = simulate(0.6, 40.0, 0.0, offset_rad=0.01)
    res = run_paramsd(t, u, r, sa, VEHICLE)
    assert np.max(np.abs(res.stiffness_factor - 1.0)) < 2e-3
    # ... but it does show the steering-angle offset (the wheel held at 0.01 rad goes straight);
    # slowly, at openpilot's offset process noise (0.02°/√s).
    assert 0.003 < res.final_angle_offset < 0.011


def test_gates_hold_the_filter_below_min_speed_and_beyond_45_degrees():
    t, u, r, sa, _ = simulate(0.6, 20.0, 0.5)
    slow = run_paramsd(t, np.full(t.size, 3.0), r, sa, VEHICLE, config=WIDE)
    assert not slow.active.any()
    assert slow.final_stiffness_factor == 1.0
    assert slow.final_stiffness_factor_sd == pytest.approx(0.5)  # clock held: P did not grow
    wide_angle = np.where(np.arange(t.size) % 2 == 0, math.radians(50.0), sa)
    res = run_paramsd(t, u, r, wide_angle, VEHICLE, config=WIDE)
    assert res.active.sum() == pytest.approx(t.size / 2, abs=2)


def test_derived_figures_and_to_dict():
    t, u, r, sa, _ = simulate(0.8, 30.0, 0.5)
    res = run_paramsd(t, u, r, sa, VEHICLE, config=WIDE)
    v = VEHICLE
    L, a = v.wheelbase_m, v.cog_to_front_axle_m
    x = res.final_stiffness_factor
    cf, cr = x * res.nominal_stiffness_front_n_per_rad, x * res.nominal_stiffness_rear_n_per_rad
    k = (v.mass_kg / L) * ((L - a) / cf - a / cr)
    ug = res.understeer_gradient
    assert ug["mean"] == pytest.approx(k)
    assert ug["bounds_2sd"][0] < ug["hdi_90"][0] < k < ug["hdi_90"][1] < ug["bounds_2sd"][1]
    cyf = res.c_y_front
    assert cyf["mean"] == pytest.approx(cf / (v.mass_kg * GRAVITY_MPS2 * (L - a) / L))
    assert cyf["bounds_2sd"][1] - cyf["bounds_2sd"][0] == pytest.approx(4 * cyf["sd"])
    d = res.to_dict(trajectories=True)
    json.dumps(d)
    assert set(d) >= {"c_y_front", "c_y_rear", "understeer_gradient", "steering_ratio"}
    assert len(d["stiffness_factor"]) == t.size
    st = res.stability()
    assert st["stiffness_factor_min"] <= x <= st["stiffness_factor_max"]


def test_bad_input_is_refused():
    t = np.arange(10.0)
    with pytest.raises(ValueError, match="speed expected length 10"):
        run_paramsd(t, np.ones(9), np.zeros(10), np.zeros(10), VEHICLE)
    with pytest.raises(ValueError, match="strictly increasing"):
        run_paramsd(t[::-1], np.ones(10), np.zeros(10), np.zeros(10), VEHICLE)
    with pytest.raises(ValueError, match="lateral_acceleration"):
        run_paramsd(
            t, np.ones(10), np.zeros(10), np.zeros(10), VEHICLE, config=ParamsdConfig(use_ay=True)
        )
