"""The deconvolved force density that gives the model E[ρ_true | ρ_obs] (Tweedie's formula)."""

import numpy as np
import pytest

from tyrebayes._errors import BadInputError
from tyrebayes.inference.tyre.force_density import deconvolve_forces, force_density_score


def test_gaussian_forces_deconvolve_to_their_own_spread():
    # True forces Normal(0.05, 0.03²) measured with noise 0.02: the mixture of the true forces
    # has the true mean and variance, and the score is the straight line −(ρ − m)/(s² + η²).
    rng = np.random.default_rng(0)
    m, s, eta = 0.05, 0.03, 0.02
    rho = rng.normal(m, s, 20_000) + rng.normal(0.0, eta, 20_000)
    noise = np.full(rho.size, eta)
    weights, means, variances, iterations, converged = deconvolve_forces(rho, noise)
    assert converged and iterations < 400
    mean = np.sum(weights * means)
    variance = np.sum(weights * (variances + means**2)) - mean**2
    assert mean == pytest.approx(m, abs=0.002)
    assert np.sqrt(variance) == pytest.approx(s, rel=0.05)
    score, slope = force_density_score(rho, noise)
    inner = np.abs(rho - m) < 1.5 * np.hypot(s, eta)
    assert np.median(slope[inner]) == pytest.approx(-1.0 / (s**2 + eta**2), rel=0.1)
    expected = -(rho[inner] - m) / (s**2 + eta**2)
    assert np.max(np.abs(score[inner] - expected)) < 0.1 / (s**2 + eta**2) * np.hypot(s, eta)


def test_corrected_forces_match_the_true_ones_for_skewed_forces():
    # A dense cluster and an exponential tail, with noise that varies window by window: within
    # bins of the measured force, ρ_obs + η² s(ρ_obs) is the mean of the true forces (Tweedie),
    # where the raw measurement is off by up to a noise sd.
    rng = np.random.default_rng(1)
    n = 30_000
    cluster = rng.normal(0.03, 0.01, n)
    tail = 0.02 + rng.exponential(0.08, n)
    true = np.where(rng.random(n) < 0.6, cluster, tail)
    eta = rng.uniform(0.01, 0.03, n)
    rho = true + eta * rng.normal(size=n)
    score, _ = force_density_score(rho, eta)
    corrected = rho + eta**2 * score
    raw_error, corrected_z = [], []
    for lo in np.arange(-0.02, 0.3, 0.02):
        in_bin = (rho >= lo) & (rho < lo + 0.02)
        residual = corrected[in_bin] - true[in_bin]
        raw_error.append(abs(np.mean(rho[in_bin] - true[in_bin])))
        # Mean error over its standard error, with 0.0005 of slack for the mixture's own fit.
        corrected_z.append(
            max(0.0, abs(np.mean(residual)) - 0.0005) / (np.std(residual) / np.sqrt(in_bin.sum()))
        )
    assert max(raw_error) > 0.01
    assert max(corrected_z) < 3.5


def test_score_rejects_non_finite_forces_and_zero_noise():
    with pytest.raises(BadInputError, match="expected at least 2 finite forces"):
        force_density_score(np.array([0.1, np.nan, 0.2]), np.full(3, 0.01))
    with pytest.raises(BadInputError, match="noise sd > 0"):
        force_density_score(np.array([0.1, 0.2, 0.3]), np.zeros(3))


def test_em_that_runs_out_of_steps_says_so(monkeypatch):
    import tyrebayes.inference.tyre.force_density as force_density

    rng = np.random.default_rng(2)
    rho = np.concatenate([rng.normal(0.02, 0.01, 3000), rng.exponential(0.1, 1000)])
    monkeypatch.setattr(force_density, "_MAX_ITERATIONS", 3)
    mixture = deconvolve_forces(rho, np.full(rho.size, 0.01))
    assert (mixture.iterations, mixture.converged) == (3, False)
