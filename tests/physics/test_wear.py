"""Tests of the energy rates, the wear integral, relative wear and the abrasability extension."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.physics.thermal import StiffnessTemperature, ThermalParams
from tyrebayes.physics.wear import (
    Abrasability,
    abrasability_at_temperature,
    bin_by_temperature,
    energy_rate_lateral,
    energy_rate_longitudinal,
    linear_slip_energy_rate,
    relative_wear,
    relative_wear_difference,
    simulate_constant_traction,
    slip_work_kernel,
    steady_constant_traction,
    wear_integral,
)

V100 = 100 / 3.6
FZ = 4865.0  # thesis Table 6.1


def test_energy_rates_by_hand_and_sign_free():
    # Table 6.1: F_x = 0.1 * 4865 = 486.5 N, V = 27.778 m/s, sigma = 0.1 / 29.
    # hand: 486.5 * 27.7778 * 0.00344828 = 46.5996 W
    w = energy_rate_longitudinal(486.5, V100, 0.1 / 29.0)
    assert float(w) == pytest.approx(46.5996, abs=1e-4)
    assert float(energy_rate_longitudinal(-486.5, V100, -0.1 / 29.0)) == float(w)
    assert float(energy_rate_longitudinal(-486.5, V100, 0.1 / 29.0)) == float(w)
    assert float(energy_rate_lateral(-1200.0, 20.0, 0.02)) == pytest.approx(480.0, rel=1e-14)
    assert float(linear_slip_energy_rate(0.1, FZ, V100, 29.0)) == pytest.approx(float(w), 1e-12)


def test_wear_integral_trapezoid_by_hand():
    t = jnp.array([0.0, 10.0, 30.0])
    w = jnp.array([2.0, 4.0, 0.0])
    # gamma * (10 * (2 + 4) / 2 + 20 * (4 + 0) / 2) = 0.1 * 70 = 7
    assert float(wear_integral(t, w, 0.1)) == pytest.approx(7.0, rel=1e-14)
    # per-sample gamma: 10*(0.1*2 + 0.2*4)/2 + 20*(0.2*4 + 0)/2 = 5 + 8 = 13
    assert float(wear_integral(t, w, jnp.array([0.1, 0.2, 0.3]))) == pytest.approx(13.0, 1e-14)


def test_relative_wear_forms_by_hand():
    assert float(relative_wear(6.0, 4.0)) == 1.5
    assert float(relative_wear_difference(4.0, 6.0)) == pytest.approx(1 / 3, rel=1e-15)
    # symmetric in its arguments, absolute value
    assert float(relative_wear_difference(6.0, 4.0)) == pytest.approx(1 / 3, rel=1e-15)
    assert float(relative_wear_difference(5.0, 5.0)) == 0.0


def test_kappa_zero_reproduces_baseline_exactly():
    t = jnp.linspace(0.0, 600.0, 61)
    temp = 10.0 + 40.0 * t / 600.0
    w = 20.0 + jnp.sin(t / 50.0)
    base = wear_integral(t, w, 0.02)
    gamma_t = abrasability_at_temperature(Abrasability(0.02, 0.0), temp)
    assert float(wear_integral(t, w, gamma_t)) == float(base)
    hotter = abrasability_at_temperature(Abrasability(0.02, 0.02), temp)
    assert float(wear_integral(t, w, hotter)) > float(base)


def test_abrasability_by_hand_and_validation():
    a = Abrasability(0.02, 0.03)
    assert float(abrasability_at_temperature(a, 20.0)) == pytest.approx(0.02, rel=1e-15)
    assert float(abrasability_at_temperature(a, 30.0)) == pytest.approx(0.02 * np.exp(0.3), 1e-14)
    with pytest.raises(ValueError, match="gamma_ref_mm3_per_j"):
        Abrasability(0.0)
    with pytest.raises(ValueError, match="temperature_sensitivity_per_k"):
        Abrasability(0.02, 0.5)


def test_thesis_loop_steady_state_and_relative_wear_direction():
    thermal, comp = ThermalParams(), StiffnessTemperature()
    out = {}
    for c_xr in (29.0, 60.0):
        for amb in (7.0, 40.0):
            out[c_xr, amb] = steady_constant_traction(thermal, comp, c_xr, 0.1, FZ, V100, amb)
    # soft tyre dissipates more (eq. 4.27), hot ambient more than cold (thesis Fig. 6.4)
    assert float(out[29.0, 7.0][2]) > float(out[60.0, 7.0][2])
    assert float(out[29.0, 40.0][2]) > float(out[29.0, 7.0][2])
    # friction power barely changes the temperature: < 0.5 K soft vs stiff (thesis Fig. 6.5/6.6)
    assert abs(float(out[29.0, 7.0][0] - out[60.0, 7.0][0])) < 0.5
    # thesis Fig. 6.7: relative wear difference larger for the stiffer tyre with this compensation
    soft = relative_wear_difference(out[29.0, 7.0][2], out[29.0, 40.0][2])
    stiff = relative_wear_difference(out[60.0, 7.0][2], out[60.0, 40.0][2])
    assert float(stiff) > float(soft)
    # the time-domain loop settles on the steady state
    run = simulate_constant_traction(
        thermal, comp, 29.0, 0.1, FZ, V100, 7.0, jnp.linspace(0.0, 4 * 3600.0, 481)
    )
    assert float(run.tyre_temperature_c[-1]) == pytest.approx(float(out[29.0, 7.0][0]), abs=1e-6)
    assert float(run.energy_rate_w[-1]) == pytest.approx(float(out[29.0, 7.0][2]), rel=1e-6)


def test_steady_loop_gradient_matches_finite_difference():
    thermal, comp = ThermalParams(), StiffnessTemperature()

    def w(c_xr):
        return steady_constant_traction(thermal, comp, c_xr, 0.1, FZ, V100, 25.0)[2]

    g = jax.grad(w)(40.0)
    fd = (float(w(40.0 + 1e-5)) - float(w(40.0 - 1e-5))) / 2e-5
    assert float(g) == pytest.approx(fd, rel=1e-7)
    assert float(g) < 0  # stiffer tyre, less slip work


def test_kernel_and_temperature_binning_reconstruct_work():
    key = jax.random.PRNGKey(0)
    n = 500
    rho = 0.1 * jax.random.normal(key, (n,))
    temps = jnp.linspace(12.3, 47.9, n)
    k = slip_work_kernel(rho, FZ, V100, 1.0)
    # work with constant C_x = kernel / C_x, matches the energy rate * dt
    np.testing.assert_allclose(k / 35.0, linear_slip_energy_rate(rho, FZ, V100, 35.0), 1e-14)
    grid = jnp.arange(0.0, 60.0, 1.0)
    binned = bin_by_temperature(k, temps, grid)
    assert float(binned.sum()) == pytest.approx(float(k.sum()), rel=1e-13)
    # linear in T exactly, exponential to second order in the 1 K step
    np.testing.assert_allclose(binned @ grid, k @ temps, rtol=1e-12)
    f = lambda x: jnp.exp(0.04 * (x - 20.0))
    np.testing.assert_allclose(binned @ f(grid), k @ f(temps), rtol=2e-4)


def test_wear_vmaps_over_a_batch_of_parameter_sets():
    t = jnp.linspace(0.0, 60.0, 61)
    power = 40.0 + 5.0 * jnp.sin(t / 10.0)
    temp = 20.0 + 0.3 * t
    batch = Abrasability(
        gamma_ref_mm3_per_j=jnp.array([0.01, 0.02, 0.03]),
        temperature_sensitivity_per_k=jnp.array([0.0, 0.02, -0.01]),
    )
    import equinox as eqx

    wear = eqx.filter_vmap(lambda a: wear_integral(t, power, abrasability_at_temperature(a, temp)))(
        batch
    )
    one = [
        wear_integral(t, power, abrasability_at_temperature(Abrasability(g, k), temp))
        for g, k in ((0.01, 0.0), (0.02, 0.02), (0.03, -0.01))
    ]
    np.testing.assert_allclose(wear, one, rtol=1e-12)
    grad = jax.vmap(jax.grad(lambda g: wear_integral(t, power, g)))(batch.gamma_ref_mm3_per_j)
    np.testing.assert_allclose(grad, wear_integral(t, power, 1.0), rtol=1e-12)
