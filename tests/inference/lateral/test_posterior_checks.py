"""What a lateral posterior says about its drive: the prior-data conflict on the yaw inertia."""

import re

import equinox as eqx
import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import LateralPriors, cornering_observations, fit_lateral
from tyrebayes.inference.lateral.posterior_checks import PRIOR_CONFLICT_SDS, _yaw_inertia
from tyrebayes.simulate.cornering import simulate_cornering

VEHICLE = load_vehicle("compact_fwd")
PRIORS = LateralPriors()


def _draws(factor: float) -> dict:
    rng = np.random.default_rng(0)
    return {"yaw_inertia_factor": factor * np.exp(0.05 * rng.standard_normal(4000))}


def test_a_yaw_inertia_far_from_the_vehicle_files_is_a_reason():
    edge = float(np.exp(PRIOR_CONFLICT_SDS * PRIORS.yaw_inertia_log_sd))
    assert _yaw_inertia(_draws(1.0), PRIORS) == []
    assert _yaw_inertia(_draws(0.97 * edge), PRIORS) == []
    (reason,) = _yaw_inertia(_draws(1.03 * edge), PRIORS)
    pattern = r"yaw inertia pulled to 1\.6\dx the vehicle file's \(\+3\.\d prior sds\)"
    assert re.match(pattern, reason), reason
    assert _yaw_inertia(_draws(0.97 / edge), PRIORS)  # too light as well as too heavy
    # the effect left out: J_z is the vehicle file's, nothing to check
    assert _yaw_inertia({}, PRIORS) == []


@pytest.mark.parametrize(("inertia_factor", "adequate"), [(0.5, False), (1.0, True)])
def test_a_drive_whose_yaw_transients_do_not_fit_is_flagged(inertia_factor, adequate):
    # A vehicle file whose yaw inertia is half the car's: the yaw transients, which carry the
    # stiffnesses' level, do not fit with J_z near the file's, and the fit pulls it far away.
    # Flagged, and its stiffnesses are not used downstream. With the right file: not flagged.
    frame, _ = simulate_cornering(VEHICLE, duration_s=600.0, seed=21)
    vehicle = eqx.tree_at(
        lambda v: v.yaw_inertia_kgm2, VEHICLE, inertia_factor * VEHICLE.yaw_inertia_kgm2
    )
    fit = fit_lateral(cornering_observations(frame, vehicle))
    assert fit.converged
    assert fit.adequate is adequate
    if adequate:
        assert fit.unusable_reason() == ""
    else:
        assert fit.unusable_reason().startswith(
            "the lateral fit does not describe the drive: yaw inertia pulled to"
        )
