"""The measured V_max of Table 6.2 as censored data: its likelihood, the extended fit, the power."""

import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.inference.result import load_fit
from tyrebayes.inference.vmax.censored import (
    censored_loglik,
    fit_extended,
    load_table_6_2,
    pointwise_log_lik,
    power_table,
    psis_loo,
)


def test_table_6_2_loaded() -> None:
    df = load_table_6_2()
    assert len(df) == 6
    assert sorted(df["c_xr"].tolist()) == [29, 32, 36, 43, 50, 60]


def test_censored_loglik_sanity() -> None:
    lo = jnp.array([70.0, 70.0, 70.0])
    mean = jnp.array([75.0, 60.0, 75.0])
    sd = jnp.array([1.0, 1.0, 1e-3])
    ll = censored_loglik(lo, 10.0, mean, sd)
    # centred in the interval with small sd: probability ~1; far below: tiny
    assert float(ll[0]) == pytest.approx(np.log(0.9999994267), abs=1e-6)
    assert float(ll[1]) < -40.0
    assert float(ll[2]) == pytest.approx(0.0, abs=1e-12)
    # probabilities over adjacent intervals sum to one
    grid = jnp.arange(0.0, 200.0, 10.0)
    p = jnp.exp(censored_loglik(grid, 10.0, jnp.full(grid.shape, 73.0), jnp.full(grid.shape, 6.0)))
    assert float(jnp.sum(p)) == pytest.approx(1.0, abs=1e-9)


def test_extended_fit_recovers_offset_and_loo(tmp_path) -> None:
    # synthetic: sim says 55 for all, truth is 75 -> offset ~ +20 within the 10 km/h interval
    lo = np.full(6, 70.0)
    m, s = np.full(6, 55.0), np.full(6, 2.0)
    fit = fit_extended(lo, m, s, seed=1, num_samples=400)
    assert fit.kind == "vmax" and fit.diagnostics.divergences == 0
    assert 13.0 < float(np.mean(fit.draws("delta_kmh"))) < 22.0
    loo = psis_loo(pointwise_log_lik(fit))
    loaded = load_fit(fit.save(tmp_path / "vmax.nc"), kind="vmax")
    np.testing.assert_array_equal(pointwise_log_lik(loaded), pointwise_log_lik(fit))
    assert loaded.provenance == fit.provenance and loaded.converged == fit.converged
    assert np.isfinite(loo["elpd_loo"]) and loo["se"] >= 0.0


def test_power_monotone_in_step() -> None:
    rows = power_table(5.0, 5.0, steps_kmh=(10.0, 1.0), sessions=(1, 10), n_mc=4000)
    p = {(r["step_kmh"], r["sessions"]): r["p_resolve"] for r in rows}
    assert p[(1.0, 10)] > p[(10.0, 1)] + 0.1
    assert p[(1.0, 10)] > 0.9
