"""The lateral model's pieces: the derivative, the residuals at the truth, the priors' effects."""

import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import LateralPriors, cornering_observations
from tyrebayes.inference.lateral.model import (
    DEFAULT_EFFECTS,
    LATERAL_EFFECTS,
    derivative,
    residuals,
)
from tyrebayes.simulate.cornering import simulate_cornering

VEHICLE = load_vehicle("compact_fwd")


def test_five_point_derivative_is_exact_on_a_quartic():
    t = np.linspace(0.0, 2.0, 41)
    x = 0.3 * t**4 - t**3 + 2 * t
    d = np.asarray(derivative(jnp.asarray(x), float(t[1] - t[0])))
    np.testing.assert_allclose(d[2:-2], (1.2 * t**3 - 3 * t**2 + 2)[2:-2], rtol=1e-10)


def _truth_point(truth, scale: float = 1.0) -> dict:
    point = {
        "c_y_front": scale * truth.c_y_front,
        "c_y_rear": scale * truth.c_y_rear,
        "mu_y": truth.mu_y,
        "curve_shape_excess_front": truth.shape - 1.0,
        "curve_shape_excess_rear": truth.shape_rear - 1.0,
        "curve_curvature_gap_front": 1.0 - truth.curvature,
        "curve_curvature_gap_rear": 1.0 - truth.curvature_rear,
        "steering_ratio": truth.steering_ratio,
        "steering_offset": truth.steering_offset_rad,
        "ay_offset": truth.ay_offset,
        "roll_gradient": truth.roll_gradient,
    }
    return {k: jnp.asarray(v) for k, v in point.items()}


def test_residuals_vanish_at_the_truth_of_a_noise_free_drive():
    """Both equations at the simulator's own parameters: only the low-pass filter is left."""
    frame, truth = simulate_cornering(VEHICLE, duration_s=120.0, seed=5, noise=False)
    obs = cornering_observations(frame, VEHICLE)
    steer, kin = residuals(obs, _truth_point(truth))
    mask, mask_kin = np.array(obs.mask), np.array(obs.mask_kinematic)
    mask[:20] = mask_kin[:20] = False  # the low-pass filter's start
    signal = np.asarray(obs.steering)[mask] / truth.steering_ratio
    # 1e-4 rad against a road-wheel angle of ~0.05 rad; 0.05 m/s² against a_y of ~2 m/s²
    assert np.std(np.asarray(steer)[mask]) < 2e-3 * np.std(signal) + 1e-4
    assert np.std(np.asarray(kin)[mask_kin]) < 0.05


def test_effects_can_be_left_out_one_by_one():
    priors = LateralPriors()
    assert priors.effects == DEFAULT_EFFECTS and set(DEFAULT_EFFECTS) < set(LATERAL_EFFECTS)
    assert "roll" not in priors.without("roll").effects
    assert priors.adding("relaxation").effects == (*DEFAULT_EFFECTS, "relaxation")
    with pytest.raises(ValueError, match="expected one of"):
        priors.without("bank")
    with pytest.raises(ValueError, match="expected a subset"):
        LateralPriors(effects=("roll", "wind"))


def test_a_y_noise_reaches_the_kinematic_residual_whatever_the_stiffness():
    """Errors in variables: the slip angle's rate comes from the noisy a_y. The residual's noise
    part must not shrink as the tyres stiffen, or the fit reads them stiff (model docstring)."""
    frame, truth = simulate_cornering(VEHICLE, manoeuvre="steady", duration_s=120.0, seed=5,
                                      noise=False)  # fmt: skip
    clean = cornering_observations(frame, VEHICLE)
    frame["ay"] = frame["ay"] + np.random.default_rng(0).normal(0.0, 0.1, len(frame))
    noisy = cornering_observations(frame, VEHICLE)
    mask = np.asarray(clean.mask_kinematic) & np.asarray(noisy.mask_kinematic)
    noise_rms = []
    for scale in (1.0, 1.5):
        point = _truth_point(truth, scale)
        part = np.asarray(residuals(noisy, point)[1]) - np.asarray(residuals(clean, point)[1])
        noise_rms.append(np.sqrt(np.mean(part[mask] ** 2)))
    # Unfiltered, the stiffer point's noise was 15 % smaller (a_y noise 0.1 m/s²).
    assert noise_rms[1] == pytest.approx(noise_rms[0], rel=0.01)
