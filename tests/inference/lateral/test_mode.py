"""The lateral mode search: one set of compiled programs for every drive of a padded length."""

import dataclasses

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import LateralPriors, cornering_observations, mode, search
from tyrebayes.simulate.cornering import simulate_cornering

VEHICLE = load_vehicle("compact_fwd")


def test_drives_on_other_surfaces_and_clocks_reuse_the_compiled_search():
    """A drive's surface (μ_y's prior) and its clock's sample interval are data of the search's
    programs: a fleet's drives differ in both, and each would otherwise compile them anew."""
    frame, _ = simulate_cornering(VEHICLE, manoeuvre="mixed", duration_s=120.0, seed=3)
    obs = search._padded(cornering_observations(frame, VEHICLE))
    # a real clock's median interval differs from drive to drive in the fourth digit
    other = dataclasses.replace(obs, dt_s=obs.dt_s * 1.0004)
    priors = LateralPriors()
    mode._weighted_mode(obs, priors, "dry", 50)
    compiled = (mode._bfgs._cache_size(), mode._hessian._cache_size())
    mode._weighted_mode(other, priors, "snow", 50)
    assert (mode._bfgs._cache_size(), mode._hessian._cache_size()) == compiled
