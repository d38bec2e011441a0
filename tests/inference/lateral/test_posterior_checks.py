"""What a lateral posterior says about its drive: the prior-data conflict on the yaw inertia."""

import re

import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import LateralPriors, cornering_observations, fit_lateral
from tyrebayes.inference.lateral.posterior_checks import PRIOR_CONFLICT_SDS, _yaw_inertia
from tyrebayes.simulate import simulate_drive
from tyrebayes.simulate.cornering import simulate_cornering
from tyrebayes.streams import validate_stream

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


@pytest.mark.parametrize(
    ("simulated", "adequate"),
    [("drive", False), ("cornering", True)],
)
def test_a_drive_whose_yaw_transients_do_not_fit_is_flagged(simulated, adequate):
    # The longitudinal drive simulator's corners are slow; on this drive (seed 2 of
    # benchmarks/results/lateral_simulated_drives.json) the fit pulls J_z far from the vehicle
    # file's, with c_y about twice the truth: flagged, and its stiffnesses are not used
    # downstream. The cornering simulator's mixed drive has strong transients: not flagged.
    if simulated == "drive":
        frame, _ = simulate_drive(2, VEHICLE, "summer", duration_s=600.0, sample_rate_hz=100.0)
        frame = validate_stream(frame, VEHICLE).data
    else:
        frame, _ = simulate_cornering(VEHICLE, duration_s=600.0, seed=21)
    fit = fit_lateral(cornering_observations(frame, VEHICLE))
    assert fit.converged
    assert fit.adequate is adequate
    if adequate:
        assert fit.unusable_reason() == ""
    else:
        assert fit.unusable_reason().startswith(
            "the lateral fit does not describe the drive: yaw inertia pulled to"
        )
