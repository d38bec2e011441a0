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


def _plain_em(rho, noise_sd, mixture, steps):
    """Plain EM, ``steps`` steps from ``mixture``: the map the accelerated EM extrapolates.

    Returns the mixture and the mean log-likelihood per window of every step's input.
    """
    import jax
    import jax.numpy as jnp

    from tyrebayes.inference.tyre.force_density import _Components, _em_step

    with jax.enable_x64(True):
        x, noise2 = jnp.asarray(rho), jnp.asarray(np.asarray(noise_sd) ** 2)
        weight = jnp.ones_like(x)

        def step(current, _):
            following, log_lik = _em_step(x, noise2, weight, current)
            return following, log_lik

        start = _Components(*(jnp.asarray(a) for a in mixture))
        final, log_liks = jax.jit(lambda s: jax.lax.scan(step, s, None, length=steps))(start)
        mixture = (final.weights, final.means, final.variances)
        return [np.asarray(a) for a in mixture], np.asarray(log_liks)


def _mean_log_lik(rho, noise_sd, weights, means, variances):
    total = variances + noise_sd[:, None] ** 2
    density = weights * np.exp(-0.5 * (rho[:, None] - means) ** 2 / total) / np.sqrt(total)
    return np.mean(np.log(np.sum(density, axis=1) / np.sqrt(2 * np.pi)))


def _skewed_drive(seed, n=6000):
    # A dense cruising cluster and a tail of accelerations, noise varying window by window.
    rng = np.random.default_rng(seed)
    true = np.where(rng.random(n) < 0.6, rng.normal(0.03, 0.01, n), 0.02 + rng.exponential(0.08, n))
    eta = rng.uniform(0.01, 0.03, n)
    return true + eta * rng.normal(size=n), eta


def test_em_step_is_extreme_deconvolution_in_numpy():
    # One step of the compiled map against the textbook (windows × components) formulas.
    rho, eta = _skewed_drive(3, n=500)
    weights, means, variances = (
        np.array([0.5, 0.3, 0.2]),
        np.array([0.0, 0.05, 0.2]),
        np.full(3, 1e-3),
    )
    total = variances + eta[:, None] ** 2
    density = weights * np.exp(-0.5 * (rho[:, None] - means) ** 2 / total) / np.sqrt(total)
    resp = density / density.sum(axis=1, keepdims=True)
    post_mean = means + variances / total * (rho[:, None] - means)
    post_var = variances - variances**2 / total
    count = resp.sum(axis=0)
    new_means = (resp * post_mean).sum(axis=0) / count
    new_variances = (resp * ((post_mean - new_means) ** 2 + post_var)).sum(axis=0) / count
    (w, m, v), _ = _plain_em(rho, eta, (weights, means, variances), 1)
    np.testing.assert_allclose(w, count / rho.size, rtol=1e-10)
    np.testing.assert_allclose(m, new_means, rtol=1e-10)
    np.testing.assert_allclose(v, new_variances, rtol=1e-10)


def test_accelerated_em_reaches_the_plain_em_fixed_point():
    # Three well-separated true components: plain EM converges (to round-off, in 3,000 steps)
    # and the accelerated EM stops at the same mixture and the same E[ρ_true | ρ_obs], in far
    # fewer EM steps, each cycle at least as likely as the last.
    rng = np.random.default_rng(4)
    n = 4000
    true = rng.choice([-0.1, 0.05, 0.3], n, p=[0.2, 0.5, 0.3]) + rng.normal(0.0, 0.02, n)
    eta = rng.uniform(0.01, 0.03, n)
    rho = true + eta * rng.normal(size=n)
    mixture = deconvolve_forces(rho, eta, n_components=3)
    assert mixture.converged and mixture.iterations < 100
    start = (np.full(3, 1 / 3), np.quantile(rho, [1 / 6, 1 / 2, 5 / 6]), np.full(3, 1e-3))
    (w, m, v), log_liks = _plain_em(rho, eta, start, 3000)
    assert log_liks[-1] - log_liks[-2] < 1e-13
    order = np.argsort(mixture.means)
    np.testing.assert_allclose(mixture.means[order], np.sort(m), atol=1e-4)
    np.testing.assert_allclose(mixture.weights[order], w[np.argsort(m)], atol=1e-3)
    np.testing.assert_allclose(mixture.variances[order], v[np.argsort(m)], rtol=0.02)
    assert _mean_log_lik(rho, eta, mixture.weights, mixture.means, mixture.variances) > (
        log_liks[-1] - 0.5 * np.log(2 * np.pi) - 1e-6
    )


def test_accelerated_em_never_lowers_the_likelihood(monkeypatch):
    # Stopped after every number of cycles in turn, the mixture's log-likelihood never falls,
    # and ends above plain EM's after the same number of EM steps (a skewed drive, where plain
    # EM is slow).
    import tyrebayes.inference.tyre.force_density as force_density

    rho, eta = _skewed_drive(5)
    monkeypatch.setattr(force_density, "_TOLERANCE", -1.0)  # never stop on the gain
    log_liks = []
    for steps in (3, 6, 9, 15, 30, 60, 120):
        monkeypatch.setattr(force_density, "_MAX_ITERATIONS", steps)
        mixture = deconvolve_forces(rho, eta)
        assert mixture.iterations == steps and not mixture.converged
        log_liks.append(_mean_log_lik(rho, eta, mixture.weights, mixture.means, mixture.variances))
    assert np.all(np.diff(log_liks) >= -1e-12)
    k = force_density.N_COMPONENTS
    start = (
        np.full(k, 1 / k),
        np.quantile(rho, (np.arange(k) + 0.5) / k),
        np.full(k, np.var(rho) / k**2),
    )
    (w, m, v), _ = _plain_em(rho, eta, start, 120)
    assert log_liks[-1] > _mean_log_lik(rho, eta, w, m, v)


def test_single_precision_windows_give_the_double_precision_corrections(monkeypatch):
    # The EM's per-window arithmetic in float32 (WINDOW_DTYPE) moves E[ρ_true | ρ_obs] by a
    # small fraction of a window's noise sd from the float64 EM's (its sums stay in float64).
    import tyrebayes.inference.tyre.force_density as force_density

    rho, eta = _skewed_drive(6, n=8000)
    corrected = {}
    for dtype in (np.float32, np.float64):
        monkeypatch.setattr(force_density, "WINDOW_DTYPE", dtype)
        mixture = deconvolve_forces(rho, eta)
        assert mixture.means.dtype == np.float64
        score, _ = force_density_score(rho, eta)
        corrected[dtype] = rho + eta**2 * score
    moved = np.abs(corrected[np.float32] - corrected[np.float64]) / eta
    assert np.max(moved) < 0.1
    assert np.sqrt(np.mean(moved**2)) < 0.01
