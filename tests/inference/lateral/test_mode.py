"""The lateral mode search: one set of compiled programs for every drive of a padded length."""

import dataclasses

import jax
import numpy as np

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import LateralPriors, cornering_observations, mode, search
from tyrebayes.internal.jax_cache import point_compilation_cache
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


def test_a_worker_that_dropped_its_programs_reads_the_search_from_disk(
    compilation_cache_dir, monkeypatch
):
    """A fleet worker over its memory budget drops every compiled program; the search's traced
    programs are read back from the compilation cache's folder, not traced again, and give the
    same mode as the plain jitted functions."""
    frame, _ = simulate_cornering(VEHICLE, manoeuvre="mixed", duration_s=60.0, seed=5)
    obs = search._padded(cornering_observations(frame, VEHICLE))
    priors = LateralPriors()
    mode._stored.cache_clear()
    point_compilation_cache(None)
    plain = mode._weighted_mode(obs, priors, "dry", 50)
    point_compilation_cache(str(compilation_cache_dir))
    mode._stored.cache_clear()
    stored = mode._weighted_mode(obs, priors, "dry", 50)
    assert list((compilation_cache_dir / "tyrebayes-programs").glob("*.jaxexport"))

    jax.clear_caches()
    mode._stored.cache_clear()
    exports = []
    export = jax.export.export
    monkeypatch.setattr(jax.export, "export", lambda *a, **k: exports.append(1) or export(*a, **k))
    again = mode._weighted_mode(obs, priors, "dry", 50)
    assert exports == []
    for got in (stored, again):
        np.testing.assert_allclose(got[0], plain[0], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(got[2], plain[2], rtol=1e-9)


def test_a_mode_far_from_mu_ys_prior_is_searched_for_again_from_it():
    """The package's drive simulator (brush curve, load transfer) on a dry road: from the
    priors' medians the search ended in a minimum at a low μ_y that the drive seemed to near
    (a claim on a dry road) with c_y high; the lower minimum lies near the prior's μ_y."""
    from tyrebayes import fit_lateral, validate_stream
    from tyrebayes.simulate import simulate_drive

    frame, truth = simulate_drive(6, VEHICLE, "summer", duration_s=600.0, sample_rate_hz=100.0)
    obs = cornering_observations(validate_stream(frame, VEHICLE).data, VEHICLE)
    d = fit_lateral(obs).to_dict()
    assert not d["mu_y_observed"], d["mu_y"]
    for axle in ("c_y_front", "c_y_rear"):
        assert abs(d[axle]["mean"] / truth.c_y_per_rad - 1.0) < 0.08, (axle, d[axle])
