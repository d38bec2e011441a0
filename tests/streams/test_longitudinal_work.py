"""Longitudinal friction work: against a hand computation, and the braking split."""

import numpy as np
import pytest

from tyrebayes.physics.vehicle import GRAVITY_MPS2
from tyrebayes.streams import compute_features
from tyrebayes.streams.longitudinal_work import (
    ENGINE_BRAKE_SHARE,
    _corrected_slip,
    _free_slip_ratios,
    braking_split,
)
from tyrebayes.streams.wear_evidence import drive_wear_evidence

from .test_wear_evidence import VEHICLE, _drive


@pytest.fixture(scope="module")
def drive():
    return _drive(3)


def test_friction_work_against_a_hand_computation(drive):
    """W_x of the driven axle = Σ F_x V σ_x dt (traction, eq. 4.19a) + Σ ρ² F_z V dt / Ĉ_x."""
    stream, truth = drive
    feats = compute_features(stream, VEHICLE)
    ev = drive_wear_evidence(stream, VEHICLE, features=feats)
    dt = 1.0 / feats.sample_rate_hz
    c_hat = ev.secant_stiffness
    slip = _corrected_slip(feats, _free_slip_ratios(feats, [0], c_hat), "fwd")
    sigma = slip[:, :2].mean(axis=1)
    fx = braking_split(feats.fx_axle_n, feats.fz_axle_n, VEHICLE)[:, 0]
    fz, v = feats.fz_axle_n[:, 0], feats.vx_mps
    ok = feats.valid & np.isfinite(fx) & np.isfinite(sigma) & ~feats.spin
    pull = ok & (fx > 0)
    hand = np.sum(fx[pull] * v[pull] * sigma[pull]) * dt
    rest = ok & ~(fx > 0)
    hand += np.sum((fx[rest] / fz[rest]) ** 2 * fz[rest] * v[rest]) * dt / c_hat
    assert ev.work_x_j[0] == pytest.approx(hand, rel=1e-9)
    # and the secant stiffness is the traction kernel over the measured traction work
    kernel = np.sum((fx[pull] / fz[pull]) ** 2 * fz[pull] * v[pull]) * dt
    measured = np.sum(fx[pull] * v[pull] * sigma[pull]) * dt
    assert c_hat == pytest.approx(kernel / measured, rel=1e-9)
    # physics: a front-driven car's front tyres do most of the work; the scale is the
    # simulator's within the stated evidence error (benchmarks/results/wear_history.json)
    true = np.sum(
        np.abs(truth.rho_x * truth.wheel_load_n * truth.wheel_centre_speed_mps * truth.slip), axis=0
    ) * np.mean(np.diff(truth.time_s))
    assert ev.work_x_j[0] > 5 * ev.work_x_j[1]
    assert 0.5 < ev.work_x_j[0] / true[:2].sum() < 1.5
    assert 0 < ev.work_x_sd_j[0] < 0.2 * ev.work_x_j[0]


def test_braking_split_puts_engine_drag_on_the_driven_axle():
    weight = VEHICLE.mass_kg * GRAVITY_MPS2
    fz = np.array([[8000.0, 6000.0]] * 3)
    coast = -0.5 * ENGINE_BRAKE_SHARE * weight
    hard = -0.5 * weight
    fx = np.array([[0.7 * coast, 0.3 * coast], [0.7 * hard, 0.3 * hard], [900.0, 0.0]])
    out = braking_split(fx, fz, VEHICLE)
    assert out.sum(axis=1) == pytest.approx(fx.sum(axis=1))  # the total is kept
    assert out[0] == pytest.approx([coast, 0.0])  # coasting: engine drag on the driven front
    engine = -ENGINE_BRAKE_SHARE * weight
    assert out[1, 0] == pytest.approx(engine + (hard - engine) * 8000.0 / 14000.0)
    assert out[2] == pytest.approx(fx[2])  # traction as it was
