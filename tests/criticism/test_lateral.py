"""Each lateral effect's ELPD gain: found where the drive has the effect, not where it lacks it."""

from __future__ import annotations

import numpy as np

from tyrebayes._domain import load_vehicle
from tyrebayes.criticism.lateral import criticize_lateral_effects
from tyrebayes.inference.lateral import cornering_observations
from tyrebayes.simulate.cornering import simulate_cornering

VEHICLE = load_vehicle("compact_fwd")


def _gain(rear_shape: float, rear_curvature: float):
    frame, _ = simulate_cornering(
        VEHICLE,
        duration_s=240.0,
        seed=13,
        mu_y=0.7,
        shape=1.25,
        curvature=-1.2,
        shape_rear=rear_shape,
        curvature_rear=rear_curvature,
    )
    obs = cornering_observations(frame, VEHICLE)
    (gain,) = criticize_lateral_effects(obs, effects=("axle_shapes",)).gains
    return gain


def test_per_axle_curve_shapes_are_found_where_the_axles_bend_differently():
    gain = _gain(1.6, 0.0)
    assert gain.effect == "axle_shapes" and gain.in_default
    assert gain.found and np.isfinite(gain.elpd_gain_se), gain
    assert (
        gain.without["understeer_gradient"]["mean"]
        < gain.with_effect["understeer_gradient"]["mean"]
    )


def test_per_axle_curve_shapes_are_not_found_where_both_axles_share_one():
    gain = _gain(1.25, -1.2)
    assert not gain.found, gain
