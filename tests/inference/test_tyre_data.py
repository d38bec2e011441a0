"""Window observations: the density score that gives the model E[ρ_true | ρ_obs]."""

import numpy as np
import pytest

from tyrebayes._errors import BadInputError
from tyrebayes.inference.tyre_data import force_density_score, stack_drives


def test_score_of_gaussian_forces_is_linear():
    # For ρ ~ Normal(m, s): d/dρ log p = −(ρ − m)/s², its slope −1/s² (KDE widens s slightly).
    rng = np.random.default_rng(0)
    m, s = 0.05, 0.03
    rho = rng.normal(m, s, 20_000)
    score, slope = force_density_score(rho)
    inner = np.abs(rho - m) < 1.5 * s
    widened = s**2 + (0.9 * s * rho.size ** (-0.2)) ** 2  # Silverman bandwidth² added
    fitted_slope, intercept = np.polyfit(rho[inner] - m, score[inner], 1)
    assert fitted_slope == pytest.approx(-1.0 / widened, rel=0.05)
    assert abs(intercept) < 0.05 / s
    # Kernel-estimate noise around the line stays small against the score's range (±1.5/s).
    assert np.std(score[inner] - (fitted_slope * (rho[inner] - m) + intercept)) < 0.2 / s
    assert np.median(slope[inner]) == pytest.approx(-1.0 / widened, rel=0.2)


def test_score_follows_a_skewed_distribution():
    # Exponential forces above 0.02: the score is −1/scale away from the edge, not a Gaussian's
    # straight line through the mean.
    rng = np.random.default_rng(1)
    rho = 0.02 + rng.exponential(0.05, 20_000)
    score, _ = force_density_score(rho)
    tail = (rho > 0.08) & (rho < 0.15)
    assert np.median(score[tail]) == pytest.approx(-1.0 / 0.05, rel=0.15)


def test_score_rejects_non_finite_forces():
    with pytest.raises(BadInputError, match="expected at least 2 finite forces"):
        force_density_score(np.array([0.1, np.nan, 0.2]))


def test_stacked_abs_windows_get_no_score():
    rng = np.random.default_rng(2)
    n = 40
    windows = {
        "slip": rng.normal(0.002, 0.001, n),
        "rho": np.concatenate([rng.normal(0.05, 0.02, n - 5), np.full(5, -0.9)]),
        "slip_sd": np.full(n, 1e-3),
        "rho_sd": np.full(n, 0.01),
        "temperature_c": np.full(n, 20.0),
        "neighbour_slip": np.zeros(n),
        "at_limit": np.arange(n) >= n - 5,
    }
    obs = stack_drives([windows], ["dry"])
    score = np.asarray(obs.rho_score)
    assert np.all(score[n - 5 : n] == 0.0) and np.all(score[n:] == 0.0)
    assert np.all(np.isfinite(score[: n - 5])) and np.any(score[: n - 5] != 0.0)
