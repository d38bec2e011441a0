"""Lateral fits on the package's own cornering drives: recovery, the steady-only case, round trips.

The simulator shares the model's assumptions (a test of the code); the external drives of
``benchmarks/lateral_external.py`` test the method. Every drive here has one length, so the fit
is compiled once for the module.
"""

import dataclasses

import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import LateralPriors, cornering_observations, fit_lateral
from tyrebayes.inference.result import load_fit
from tyrebayes.inference.tyre.result import TyreFit
from tyrebayes.simulate.cornering import simulate_cornering

pytestmark = pytest.mark.early
VEHICLE = load_vehicle("compact_fwd")
DURATION_S = 240.0


@pytest.fixture(scope="module")
def mixed():
    frame, truth = simulate_cornering(VEHICLE, manoeuvre="mixed", duration_s=DURATION_S, seed=11)
    return fit_lateral(cornering_observations(frame, VEHICLE), seed=1), truth


@pytest.fixture(scope="module")
def steady():
    frame, truth = simulate_cornering(VEHICLE, manoeuvre="steady", duration_s=DURATION_S, seed=12)
    return fit_lateral(cornering_observations(frame, VEHICLE), seed=1), truth


def test_mixed_drive_recovers_both_axles_and_the_nuisances(mixed):
    fit, truth = mixed
    d = fit.to_dict()
    assert d["converged"] and d["adequate"] and d["identified"]
    for key, value in (
        ("c_y_front", truth.c_y_front),
        ("c_y_rear", truth.c_y_rear),
        ("understeer_gradient", truth.understeer_gradient),
        ("roll_gradient", truth.roll_gradient),
    ):
        # within two posterior sds (one fixed drive: a 90 % interval misses one time in ten)
        assert abs(d[key]["mean"] - value) <= 2.0 * d[key]["sd"], (key, d[key], value)
        assert abs(d[key]["mean"] / value - 1.0) < 0.08, (key, d[key]["mean"], value)
    # the ratio is found to 0.1 % from the low-speed turns; its interval is narrower still
    assert abs(d["steering_ratio"]["mean"] / truth.steering_ratio - 1.0) < 0.003
    # μ_y was not neared (|a_y| ≤ 5 m/s² on a μ = 1 road): not claimed, not reported
    assert not d["mu_y_observed"] and d["mu_y"] is None


def test_steady_cornering_gives_a_tight_gradient_and_a_wide_correlated_split(steady, mixed):
    fit, truth = steady
    d = fit.to_dict()
    assert d["converged"] and d["identified"]
    # At one speed the steering ratio and the gradient trade off (δ_sw/i = (L/V² + K) a_y):
    # the gradient rests on the ratio's prior and is found to 15 %, not to its interval.
    assert abs(d["understeer_gradient"]["mean"] / truth.understeer_gradient - 1.0) < 0.15
    k_rel = d["understeer_gradient"]["sd"] / abs(d["understeer_gradient"]["mean"])
    c_rel = d["c_y_front"]["sd"] / d["c_y_front"]["mean"]
    assert d["front_rear_correlation"] > 0.8
    # the axles move together and each is several times wider than on the mixed drive, while
    # the gradient stays within 10 % (1 sd)
    assert c_rel > 5 * d_rel(mixed[0], "c_y_front") and k_rel < 0.10


def d_rel(fit, key: str) -> float:
    d = fit.to_dict()[key]
    return d["sd"] / abs(d["mean"])


def test_axles_whose_curves_bend_differently_are_each_read_on_their_own_curve():
    """A rear curve that bends earlier than the front's (within the measured tyres' spread) on a
    road of μ 0.7, where the corners use up to 0.7 of the peak. With one curve shape for both
    axles (``axle_shapes`` left out) the understeer gradient reads more than 10 % low."""
    frame, truth = simulate_cornering(
        VEHICLE,
        duration_s=DURATION_S,
        seed=13,
        mu_y=0.7,
        shape=1.25,
        curvature=-1.2,
        shape_rear=1.6,
        curvature_rear=0.0,
    )
    obs = cornering_observations(frame, VEHICLE)
    fit = fit_lateral(obs, seed=1)
    d = fit.to_dict()
    assert d["converged"] and d["adequate"], d["adequacy_reasons"]
    assert abs(d["understeer_gradient"]["mean"] / truth.understeer_gradient - 1.0) < 0.05
    for key, value in (("c_y_front", truth.c_y_front), ("c_y_rear", truth.c_y_rear)):
        assert abs(d[key]["mean"] / value - 1.0) < 0.03, (key, d[key]["mean"], value)
    # the rear's curve is the rounder one: a larger shape C
    assert fit.curve_shape("rear")[0].mean() > fit.curve_shape("front")[0].mean()
    shared = fit_lateral(obs, priors=LateralPriors().without("axle_shapes"), seed=1)
    k_shared = shared.to_dict()["understeer_gradient"]["mean"]
    assert k_shared / truth.understeer_gradient - 1.0 < -0.10
    np.testing.assert_array_equal(shared.curve_shape("rear")[0], shared.curve_shape("front")[0])


def test_a_lateral_fit_round_trips_through_the_tyre_fit_file(mixed, tmp_path):
    from tyrebayes.inference.tyre.data import stack_drives
    from tyrebayes.inference.tyre.fit import fit_tyre

    from ..tyre.test_model import PAD, linear_region_windows

    tyre = fit_tyre(stack_drives([linear_region_windows(3)], ["dry"], pad_to=PAD), method="fast")
    tyre = dataclasses.replace(tyre, lateral=mixed[0])
    path = tyre.save(tmp_path / "fit.nc")
    loaded = TyreFit.from_fit(load_fit(path, kind="tyre"))
    assert loaded.lateral is not None
    assert loaded.lateral.to_dict() == mixed[0].to_dict()
    assert loaded.summary()["lateral"] == mixed[0].to_dict()
    empty = dataclasses.replace(tyre, lateral=None, lateral_reason="lateral: no usable cornering")
    again = TyreFit.from_fit(load_fit(empty.save(tmp_path / "empty.nc")))
    assert again.lateral is None and again.summary()["lateral_reason"].startswith("lateral: no")


def test_a_search_on_stretches_of_the_drive_refines_to_the_mode_of_all_samples(mixed, monkeypatch):
    """A drive searched on evenly spaced stretches, refined on all samples: the same posterior."""
    from tyrebayes.inference.lateral import search

    frame, _ = simulate_cornering(VEHICLE, manoeuvre="mixed", duration_s=DURATION_S, seed=11)
    obs = cornering_observations(frame, VEHICLE)
    monkeypatch.setattr(search, "SEARCH_SAMPLES", 800)
    assert search._search_blocks(search.padded_length(obs.speed.shape[0])) == 16
    searched = fit_lateral(obs, seed=1).to_dict()
    whole = mixed[0].to_dict()
    assert searched["converged"]
    for key in ("c_y_front", "c_y_rear", "understeer_gradient", "steering_ratio"):
        assert abs(searched[key]["mean"] - whole[key]["mean"]) < 0.01 * whole[key]["sd"], key
        # the weights come from the residuals at the subsets' unweighted mode, a point near the
        # whole's: the sds follow their VIFs' small difference
        assert abs(searched[key]["sd"] / whole[key]["sd"] - 1.0) < 0.03, key


@pytest.mark.slow
def test_nuts_agrees_with_the_laplace_fit(mixed):
    """NUTS from the Laplace mode: the same posterior centre, its own diagnostics."""
    frame, _ = simulate_cornering(VEHICLE, manoeuvre="mixed", duration_s=DURATION_S, seed=11)
    obs = cornering_observations(frame, VEHICLE)
    nuts = fit_lateral(obs, "nuts", seed=1, num_chains=2, num_warmup=150, num_samples=150)
    assert nuts.fit.diagnostics.method == "nuts" and nuts.fit.diagnostics.n_chains == 2
    laplace = mixed[0].to_dict()
    for key in ("c_y_front", "c_y_rear", "understeer_gradient"):
        a, b = nuts.to_dict()[key], laplace[key]
        assert abs(a["mean"] - b["mean"]) < 2 * b["sd"] + 1e-12, (key, a, b)
