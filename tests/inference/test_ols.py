"""Tests of the thesis' OLS baseline (tyrebayes.inference.ols)."""

import numpy as np
import pytest
from scipy import stats

from tyrebayes._errors import BadInputError
from tyrebayes.inference.ols import (
    fit_ols,
    ols_interval,
    ols_logpdf,
    ols_loo_logpdf,
    ols_predictive,
)
from tyrebayes.simulate.fleet import simulate_fleet


def test_exact_line_recovered_without_noise():
    c = np.array([25.0, 30.0, 40.0, 50.0, 60.0])
    y = 0.05 + 9.0 / c
    fit = fit_ols(c, y)
    assert fit.intercept == pytest.approx(0.05, abs=1e-12)
    assert fit.slope == pytest.approx(9.0, abs=1e-10)
    assert fit.r2 == pytest.approx(1.0)
    assert fit.resid_sd == pytest.approx(0.0, abs=1e-12)


def test_matches_numpy_polyfit_and_r2_definition():
    rng = np.random.default_rng(0)
    c = rng.uniform(25, 65, 40)
    y = 0.1 + 10 / c + rng.normal(0, 0.03, 40)
    fit = fit_ols(c, y)
    slope, intercept = np.polyfit(1 / c, y, 1)
    assert fit.slope == pytest.approx(slope, rel=1e-9)
    assert fit.intercept == pytest.approx(intercept, rel=1e-9)
    resid = y - (intercept + slope / c)
    assert fit.r2 == pytest.approx(1 - np.sum(resid**2) / np.sum((y - y.mean()) ** 2))


def test_thesis_like_fleet_gives_r2_near_thesis_value():
    # Thesis Sec. 6.1: R^2 ~ 0.8 on 26 winter tests. Over 20 simulated fleets the mean R^2 must
    # be within 0.1 of it (the simulator was built to look like the thesis' data).
    r2 = [fit_ols(t["c_xr"], t["mu"]).r2 for t in (simulate_fleet(s, 26)[0] for s in range(20))]
    assert abs(np.mean(r2) - 0.8) < 0.1


def test_prediction_interval_coverage_under_model_assumptions():
    # When the data really follow the line with Gaussian noise, the 90 % t-interval covers a new
    # point 90 % of the time; 2000 replications -> binomial sd 0.7 points, tolerance 2 points.
    rng = np.random.default_rng(1)
    hits = 0
    n_rep = 2000
    for _ in range(n_rep):
        c = rng.uniform(25, 65, 12)
        y = 0.1 + 10 / c + rng.normal(0, 0.03, 12)
        c_new = rng.uniform(25, 65)
        y_new = 0.1 + 10 / c_new + rng.normal(0, 0.03)
        _, lo, hi = ols_interval(fit_ols(c, y), np.array([c_new]), 0.9)
        hits += bool(lo[0] <= y_new <= hi[0])
    assert abs(hits / n_rep - 0.9) < 0.02


def test_logpdf_is_student_t_and_loo_matches_refits():
    rng = np.random.default_rng(2)
    c = rng.uniform(25, 65, 10)
    y = 0.1 + 10 / c + rng.normal(0, 0.03, 10)
    fit = fit_ols(c, y)
    loc, scale, dof = ols_predictive(fit, c[:2])
    assert np.allclose(ols_logpdf(fit, c[:2], y[:2]), stats.t.logpdf(y[:2], dof, loc, scale))
    loo = ols_loo_logpdf(c, y)
    keep = np.arange(10) != 4
    manual = ols_logpdf(fit_ols(c[keep], y[keep]), c[4:5], y[4:5])[0]
    assert loo[4] == pytest.approx(manual)


def test_bad_input():
    with pytest.raises(BadInputError, match="at least 3"):
        fit_ols([30.0, 40.0], [0.4, 0.3])
    with pytest.raises(BadInputError, match="positive finite c_xr"):
        fit_ols([30.0, -40.0, 50.0], [0.4, 0.3, 0.2])
    with pytest.raises(BadInputError, match="equal length"):
        fit_ols([30.0, 40.0, 50.0], [0.4, 0.3])
