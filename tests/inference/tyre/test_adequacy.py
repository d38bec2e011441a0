"""Model adequacy as data: the checks fire on what the model cannot describe, not on clean data."""

import numpy as np
import pytest

from tyrebayes.inference.tyre.adequacy import MAX_STEP_T, assess_adequacy, offset_step


def _clean(seed=0, n=2000):
    rng = np.random.default_rng(seed)
    return rng.normal(size=n), rng.uniform(0.0, 0.3, n), np.zeros(n, dtype=int)


def test_clean_residuals_are_adequate():
    z, rho, drive = _clean()
    offsets = (np.random.default_rng(1).normal(0.0, 1e-4, 100),)
    result = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, block_offsets=offsets)
    assert result.adequate, result.reasons
    assert result.reasons == ()


def test_each_check_fires_with_its_reason():
    z, rho, drive = _clean()
    wide = assess_adequacy(3.0 * z, rho, drive, 1, shape_prior_sds={})
    assert not wide.adequate and "predictive band" in wide.reasons[0]
    trend = assess_adequacy(z + 40.0 * (rho - 0.15), rho, drive, 1, shape_prior_sds={})
    assert any("trend with the force" in r for r in trend.reasons)
    drift = assess_adequacy(
        z + np.repeat(np.random.default_rng(2).normal(0, 1.5, 50), 40),
        rho,
        drive,
        1,
        shape_prior_sds={},
    )
    assert any("variance inflation" in r for r in drift.reasons)
    edge = assess_adequacy(z, rho, drive, 1, shape_prior_sds={"shape C": -3.0})
    assert any("shape C" in r for r in edge.reasons)
    nan = assess_adequacy(
        np.where(np.arange(z.size) == 5, np.nan, z), rho, drive, 1, shape_prior_sds={}
    )
    assert not nan.adequate and "non-finite" in nan.reasons[0]


def test_offset_step_statistic():
    rng = np.random.default_rng(3)
    steady = rng.normal(0.0, 1e-4, 120)
    assert offset_step(steady)[0] < MAX_STEP_T
    stepped = steady + np.where(np.arange(120) >= 60, 2e-3, 0.0)
    t, size = offset_step(stepped)
    assert t > 3 * MAX_STEP_T and size == pytest.approx(2e-3, rel=0.1)
    assert offset_step(steady[:5]) == (0.0, 0.0)
    _, _, drive = _clean()
    z, rho, _ = _clean()
    jumped = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, block_offsets=(stepped,))
    assert any("steps by 0.002" in r for r in jumped.reasons), jumped.reasons
    # A drift of the same t but tiny size is not a change of tyre.
    small = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, block_offsets=(stepped / 10,))
    assert small.adequate, small.reasons
