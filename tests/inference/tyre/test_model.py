"""The per-tyre model: errors in variables against OLS attenuation, μ_max not observed.

Synthetic window observations (no simulator) keep these fast; one compiled fast-path shape
(1024 windows, one dry drive) is shared with ``test_fit.py`` through the fit cache.
"""

import jax
import numpy as np
import pytest
from numpyro import handlers

from tyrebayes.inference.result import load_fit
from tyrebayes.inference.tyre.data import WindowTable, stack_drives
from tyrebayes.inference.tyre.fit import TyreFit, fit_tyre
from tyrebayes.inference.tyre.model import TyrePriors, tyre_model
from tyrebayes.physics.tyre import brush_longitudinal, brush_longitudinal_inverse
from tyrebayes.streams.abs_detection import _inner_runs

pytestmark = pytest.mark.early  # minutes long: started first (tests/conftest.py)

C_X_TRUE = 40.0
SLIP_OFFSET_TRUE = 0.002
PAD = 1024


def linear_region_windows(seed: int, n: int = 900, slip_noise: float = 0.0012) -> WindowTable:
    """Slowly varying true slip (a driver's pedal), noisy slip and force, no ABS.

    True slip spread 0.0015, slip noise 0.0012: the reliability ratio is 0.61, so OLS of force
    on measured slip returns about 0.6 C_x.
    """
    rng = np.random.default_rng(seed)
    true = np.convolve(rng.normal(0.0, 1.0, n + 20), np.ones(8) / np.sqrt(8), "same")[10:-10]
    true = 0.0015 * true / true.std() + 0.002
    rho = np.asarray(brush_longitudinal(true - SLIP_OFFSET_TRUE, C_X_TRUE, 1.0, 1.0))
    slip = true + rng.normal(0.0, slip_noise, n)
    rho_obs = rho + rng.normal(0.0, 0.004, n)
    neighbour = np.full(n, np.nan)
    neighbour[1:-1] = 0.5 * (slip[:-2] + slip[2:])
    neighbour[0], neighbour[-1] = slip[1], slip[-2]
    return WindowTable(
        slip=slip,
        rho=rho_obs,
        slip_sd=np.full(n, slip_noise),
        rho_sd=np.full(n, 0.004),
        temperature_c=np.full(n, 20.0),
        time_s=0.25 * np.arange(n),
        neighbour_slip=neighbour,
    )


@pytest.fixture(scope="module")
def linear_fit():
    windows = linear_region_windows(0)
    obs = stack_drives([windows], ["dry"], pad_to=PAD)
    return windows, obs, fit_tyre(obs, method="fast", seed=1)


def test_ols_is_attenuated_and_the_model_is_not(linear_fit):
    windows, _, fit = linear_fit
    ols_slope = np.polyfit(windows.slip, windows.rho, 1)[0]
    # Reliability 0.0015² / (0.0015² + 0.0012²) = 0.61: OLS is visibly biased low.
    assert ols_slope < 0.75 * C_X_TRUE
    c_x = fit.summary()["c_x"]
    # Tolerance: 8 % (posterior sd here is ~3 %; fixed seeds).
    assert abs(c_x["mean"] - C_X_TRUE) / C_X_TRUE < 0.08
    assert c_x["hdi_90"][0] < C_X_TRUE < c_x["hdi_90"][1]
    assert fit.diagnostics.converged, fit.diagnostics.reason


def test_mu_max_not_observed_without_hard_braking(linear_fit):
    _, _, fit = linear_fit
    summary = fit.summary()
    assert summary["mu_max_observed"] is False
    # The posterior of μ_max stays close to the prior (median 1.0 on dry, log-sd 0.35).
    assert 0.6 < summary["mu_max"]["mean"] < 1.6


def test_inference_data_groups(linear_fit):
    _, obs, fit = linear_fit
    groups = set(fit.idata.children)
    assert {"posterior", "observed_data", "log_likelihood", "posterior_predictive"} <= groups
    assert fit.idata["observed_data"]["rho_obs"].shape == (obs.n_used,)
    assert fit.n_samples_used == 900


def test_saved_tyre_fit_loads_back_with_its_tyre_fields(linear_fit, tmp_path):
    _, _, fit = linear_fit
    assert fit.fit.kind == "tyre" and fit.fit.provenance.method == "fast"
    loaded = load_fit(fit.save(tmp_path / "tyre.nc"), kind="tyre")
    again = TyreFit.from_fit(loaded)
    assert again.model == fit.model and again.surfaces == fit.surfaces
    assert again.mu_observed == fit.mu_observed and again.n_samples_used == fit.n_samples_used
    np.testing.assert_equal(again.summary(), fit.summary())


def test_bad_model_is_a_value_error():
    obs = stack_drives([linear_region_windows(1, n=50)], ["dry"])
    with pytest.raises(ValueError, match="expected one of .*'brush'.*, got 'fiala'"):
        tyre_model(obs, TyrePriors(), model="fiala")


def test_imu_gain_uncertainty_widens_only_its_drives_force_gain_prior():
    """A drive whose forces were divided by an estimated IMU gain (log-sd 0.06) gets a force-gain
    prior of log-sd √(0.025² + 0.06²); the other drive keeps the car's own 0.025."""
    plain = linear_region_windows(3, n=50)
    dashcam = linear_region_windows(4, n=50).replace(imu_gain_log_sd=np.full(50, 0.06))
    obs = stack_drives([plain, dashcam], ["dry", "dry"])
    np.testing.assert_allclose(np.asarray(obs.imu_gain_log_sd[:100]), [0.0] * 50 + [0.06] * 50)
    with jax.numpy_rank_promotion("allow"):
        trace = handlers.trace(handlers.seed(tyre_model, 0)).get_trace(obs, TyrePriors())
    scale = np.asarray(trace["force_gain"]["fn"].scale)
    np.testing.assert_allclose(scale, [0.025, np.hypot(0.025, 0.06)], rtol=1e-6)


def test_stack_drives_checks_surfaces_and_counts():
    w = linear_region_windows(2, n=50)
    with pytest.raises(ValueError, match="expected one of"):
        stack_drives([w], ["gravel"])
    with pytest.raises(ValueError, match="one surface per drive"):
        stack_drives([w, w], ["dry"])
    short = w.select(np.arange(5))
    with pytest.raises(ValueError, match="at least 10 usable windows"):
        stack_drives([short], ["dry"])


def test_abs_runs_drop_short_runs_and_ends():
    flags = np.array([0, 1, 1, 0, 1, 1, 1, 1, 1, 0], dtype=bool)
    expected = np.array([0, 0, 0, 0, 0, 1, 1, 1, 0, 0], dtype=bool)
    np.testing.assert_array_equal(_inner_runs(flags, 4), expected)


def skewed_force_windows(seed: int, n: int = 1000) -> WindowTable:
    """A drive's forces as they are: a dense cruising cluster and a long tail of accelerations.

    Slips follow the brush curve (C_x 40, μ 1.0) with little noise; the force has Gaussian noise
    of 0.012. A Gaussian population of true forces shrinks the cluster too little and the tail
    too much, which the brush curve reads as curvature (C_x ~20 % high, μ_max halved).
    """
    rng = np.random.default_rng(seed)
    cluster = rng.normal(0.04, 0.015, n)
    tail = 0.02 + rng.exponential(0.09, n)
    rho_true = np.clip(np.where(rng.random(n) < 0.65, cluster, tail), 0.0, 0.6)
    slip_true = np.asarray(brush_longitudinal_inverse(rho_true, C_X_TRUE, 1.0)) + SLIP_OFFSET_TRUE
    return noisy_windows(rng, slip_true, rho_true, slip_sd=2e-4, rho_sd=0.012)


def noisy_windows(
    rng, slip_true, rho_true, *, slip_sd: float, rho_sd: float, **also
) -> WindowTable:
    """Windows at 20 °C, every 0.25 s, observing true slips and forces through Gaussian noise of
    the given sd (the neighbouring wheels' slip is the true one: no rolling-radius nuisance)."""
    n = len(slip_true)
    return WindowTable(
        slip=slip_true + rng.normal(0.0, slip_sd, n),
        rho=rho_true + rng.normal(0.0, rho_sd, n),
        slip_sd=np.full(n, slip_sd),
        rho_sd=np.full(n, rho_sd),
        temperature_c=np.full(n, 20.0),
        time_s=0.25 * np.arange(n),
        neighbour_slip=slip_true,
        **also,
    )


def test_skewed_force_distribution_does_not_read_as_curvature():
    obs = stack_drives([skewed_force_windows(3)], ["dry"], pad_to=PAD)
    summary = fit_tyre(obs, method="fast", seed=3).summary()
    # Tolerance 5 % on C_x (posterior sd ~2 %); a Gaussian force population gives ~+20 %.
    assert abs(summary["c_x"]["mean"] / C_X_TRUE - 1.0) < 0.05
    assert summary["mu_max"]["mean"] > 0.8


def load_transfer_windows(seed: int, load_sensitivity: float, n: int = 900) -> WindowTable:
    """A front-driven axle that unloads as it pushes: ΔF_z/F_z = −0.5 ρ, as for a compact car
    (h/l_r ≈ 0.5). Slips follow a straight line whose slope C_x exp(q ΔF_z/F_z) falls with the
    force for q > 0 (no curvature of its own: the linear model's fit sees only the load's)."""
    rng = np.random.default_rng(seed)
    rho_true = np.clip(rng.gamma(2.0, 0.06, n), 0.02, 0.5)
    load_change = -0.5 * rho_true
    stiffness = C_X_TRUE * np.exp(load_sensitivity * load_change)
    slip_true = rho_true / stiffness + SLIP_OFFSET_TRUE
    return noisy_windows(
        rng, slip_true, rho_true, slip_sd=1e-4, rho_sd=0.004, load_change=load_change
    )


def test_load_sensitivity_is_left_out_unless_its_prior_is_given():
    obs = stack_drives([load_transfer_windows(5, 0.8)], ["dry"], pad_to=PAD)
    with jax.numpy_rank_promotion("allow"):
        plain = handlers.trace(handlers.seed(tyre_model, 0)).get_trace(obs, TyrePriors())
        loaded = handlers.trace(handlers.seed(tyre_model, 0)).get_trace(
            obs, TyrePriors().with_load_sensitivity()
        )
    assert "load_sensitivity" not in plain
    assert loaded["load_sensitivity"]["fn"].loc == pytest.approx(0.263)
    assert loaded["load_sensitivity"]["fn"].scale == pytest.approx(0.246)


@pytest.mark.parametrize("truth", [0.0, 0.8])
def test_load_sensitivity_is_found_and_c_x_is_at_the_static_load(truth):
    """With the measured tyres' prior, Normal(0.263, 0.246), on q; the data hold q = 0 or the
    database's largest, 0.8. The posterior moves to the truth and C_x, the slope at the static
    load, is recovered either way."""
    obs = stack_drives([load_transfer_windows(5, truth)], ["dry"], pad_to=PAD)
    priors = TyrePriors().with_load_sensitivity()
    fit = fit_tyre(obs, priors=priors, method="fast", model="linear", seed=5)
    assert fit.diagnostics.converged, fit.diagnostics.reason
    summary = fit.summary()
    q = np.asarray(fit.draws("load_sensitivity"))
    low, high = np.quantile(q, [0.05, 0.95])
    assert low < truth < high
    assert abs(np.mean(q) - truth) < 0.12
    c_x = summary["c_x"]
    assert c_x["hdi_90"][0] < C_X_TRUE < c_x["hdi_90"][1]
    assert abs(c_x["mean"] / C_X_TRUE - 1.0) < 0.03


def test_single_precision_observations_are_an_error_not_a_failed_fit():
    import equinox as eqx
    import jax.numpy as jnp

    obs = stack_drives([linear_region_windows(1, n=50)], ["dry"])
    single = eqx.tree_at(lambda o: o.slip, obs, obs.slip.astype(jnp.float32))
    with pytest.raises(ValueError, match="expected float64 observations.*got float32"):
        fit_tyre(single, method="fast")


def test_a_one_drive_site_is_broadcast_with_the_gathers_values_and_derivatives():
    # window_likelihood broadcasts the only value of a one-drive (one-surface) site instead of
    # gathering it: same values and gradients, and no gather left in its program.
    import jax.numpy as jnp

    from tyrebayes.inference.tyre.likelihood import _per_window

    index = jnp.zeros(7, dtype=jnp.int32)
    weights = jnp.arange(7.0)

    def loss(per_window):
        return lambda site: jnp.sum(weights * jnp.sin(per_window(site)) ** 2)

    site = jnp.asarray([0.3])
    broadcast = lambda s: _per_window(s, index, 1)  # noqa: E731
    gathered = lambda s: s[index]  # noqa: E731
    np.testing.assert_array_equal(broadcast(site), gathered(site))
    hessians = [jax.hessian(loss(f))(site) for f in (broadcast, gathered)]
    np.testing.assert_allclose(hessians[0], hessians[1], rtol=1e-12)
    assert "gather" not in str(jax.make_jaxpr(jax.hessian(loss(broadcast)))(site))
    two = jnp.asarray([0.3, 0.5])
    np.testing.assert_array_equal(_per_window(two, index.at[3].set(1), 2), two[index.at[3].set(1)])


def test_the_old_curve_keyword_is_refused_naming_model():
    obs = stack_drives([linear_region_windows(1, n=50)], ["dry"])
    with pytest.raises(TypeError, match="keyword 'kind' is now 'model'"):
        tyre_model(obs, TyrePriors(), kind="brush")
