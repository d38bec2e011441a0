"""Lateral friction work: the brush slip angle, and the work at a given cornering stiffness."""

import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.simulate.wear_history import COMMUTE_PROFILE, lateral_sliding_power
from tyrebayes.streams import compute_features, validate_stream
from tyrebayes.streams.cornering_stiffness import TYPE_PRIOR_CORNERING, CorneringStiffness
from tyrebayes.streams.lateral_work import brush_slip_angle
from tyrebayes.streams.wear_evidence import drive_wear_evidence

VEHICLE = load_vehicle("compact_fwd")


def test_brush_slip_angle_is_linear_for_small_forces_and_steeper_near_the_peak():
    rho = np.array([1e-3, 0.5, 0.9])
    t = brush_slip_angle(rho, 20.0, mu=1.0)
    assert t[0] == pytest.approx(1e-3 / 20.0, rel=1e-3)
    assert t[1] > 0.5 / 20.0 and t[2] / t[1] > 0.9 / 0.5
    # W_y ∝ 1 / c_y exactly: the stiffness only scales the slip angle
    assert brush_slip_angle(rho, 10.0) == pytest.approx(2.0 * brush_slip_angle(rho, 20.0))


@pytest.fixture(scope="module")
def cornering_drive():
    df, truth = simulate_drive(
        7, VEHICLE, "summer", duration_s=240.0, sample_rate_hz=10.0, profile=COMMUTE_PROFILE
    )
    return validate_stream(df, VEHICLE), truth


def test_lateral_work_uses_the_given_stiffness(cornering_drive):
    """W_y = Σ |F_y V tan α| dt with α from the given per-axle c_y (eq. 4.19b, 4.23b, c)."""
    stream, truth = cornering_drive
    feats = compute_features(stream, VEHICLE)
    given = CorneringStiffness(truth.c_y_per_rad, 2.0 * truth.c_y_per_rad, 0.1, "lateral_fit")
    ev = drive_wear_evidence(stream, VEHICLE, features=feats, cornering=given)
    assert ev.cornering.source == "lateral_fit"
    assert ev.row()["cornering_stiffness_rear_per_rad"] == 2.0 * truth.c_y_per_rad
    dt = 1.0 / feats.sample_rate_hz
    v = feats.vx_mps
    ay, yaw_acc = v * feats.yaw_rate_radps, feats.yaw_acc_radps2
    lf, wb = VEHICLE.cog_to_front_axle_m, VEHICLE.wheelbase_m
    fy_f = (VEHICLE.mass_kg * ay * (wb - lf) + VEHICLE.yaw_inertia_kgm2 * yaw_acc) / wb
    ok = feats.valid & np.isfinite(fy_f)
    alpha = brush_slip_angle(fy_f[ok] / feats.fz_axle_n[ok, 0], truth.c_y_per_rad)
    hand = np.sum(np.abs(fy_f[ok] * v[ok] * alpha)) * dt
    assert ev.work_y_j[0] == pytest.approx(hand, rel=1e-9)
    # the type prior (16.5 /rad, softer) reads more lateral work; a stiffer rear reads less
    prior = drive_wear_evidence(stream, VEHICLE, features=feats)
    assert prior.cornering.source == "type_prior"
    assert prior.work_y_j[0] == pytest.approx(
        ev.work_y_j[0] * truth.c_y_per_rad / TYPE_PRIOR_CORNERING.front_per_rad, rel=1e-9
    )
    assert prior.work_y_j[1] == pytest.approx(
        ev.work_y_j[1] * 2.0 * truth.c_y_per_rad / TYPE_PRIOR_CORNERING.rear_per_rad, rel=1e-9
    )
    # with the true c_y the evidence reads the simulator's true lateral work (eq. 4.19b)
    true = np.sum(lateral_sliding_power(truth, VEHICLE), axis=0) * dt
    right = drive_wear_evidence(
        stream,
        VEHICLE,
        features=feats,
        cornering=CorneringStiffness(truth.c_y_per_rad, truth.c_y_per_rad, 0.0),
    )
    assert right.work_y_j == pytest.approx(true, rel=0.15)
