"""Tests of the lumped tyre temperature model and the stiffness temperature compensation."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.physics.thermal import (
    StiffnessTemperature,
    ThermalParams,
    compensate_stiffness,
    compensation_is_invertible,
    convective_conductance,
    rolling_loss_power,
    simulate_tyre_temperature,
    steady_state_temperature,
    stiffness_at_temperature,
    stiffness_with_sensitivity,
    temperature_sensitivity,
)

V100 = 100 / 3.6
FZ = 4865.0  # thesis Table 6.1


def _central_difference(f, x, h=1e-6):
    return (f(x + h) - f(x - h)) / (2 * h)


def _stack(modules):
    return jax.tree.map(lambda *xs: jnp.stack([jnp.asarray(x) for x in xs]), *modules)


def test_rolling_loss_is_about_one_kilowatt_at_100_kmh():
    # f_rr F_z V = 0.010 * 4865 N * 27.78 m/s (DESIGN.md: ~1 kW per tyre at 100 km/h).
    assert float(rolling_loss_power(ThermalParams(), FZ, V100)) == pytest.approx(1351.39, abs=0.01)


def test_steady_state_equals_analytic_balance():
    p = ThermalParams()
    friction = 40.0
    h = p.convection_still_w_per_k + p.convection_speed_w_per_k * V100**0.8
    expected = 7.0 + (0.010 * FZ * V100 + 0.5 * friction) / h
    got = steady_state_temperature(p, FZ, V100, friction, 7.0)
    assert float(got) == pytest.approx(expected, rel=1e-12)


def test_time_series_converges_to_steady_state_and_starts_at_initial():
    p = ThermalParams()
    t = jnp.linspace(0.0, 4 * 3600.0, 1441)  # 30 time constants of ~8 min
    temp = simulate_tyre_temperature(p, t, V100, FZ, 40.0, 7.0, 7.0)
    assert float(temp[0]) == 7.0
    steady = steady_state_temperature(p, FZ, V100, 40.0, 7.0)
    assert float(temp[-1]) == pytest.approx(float(steady), abs=1e-9)
    assert bool(jnp.all(jnp.diff(temp) >= 0))  # monotone warm-up from ambient


def test_exponential_step_is_exact_for_constant_inputs():
    # One step of 600 s must equal the analytic solution T_ss + (T0 - T_ss) exp(-h t / C).
    p = ThermalParams()
    temp = simulate_tyre_temperature(p, jnp.array([0.0, 600.0]), V100, FZ, 0.0, 10.0, 10.0)
    h = float(convective_conductance(p, V100))
    t_ss = float(steady_state_temperature(p, FZ, V100, 0.0, 10.0))
    expected = t_ss + (10.0 - t_ss) * np.exp(-h * 600.0 / 2.5e4)
    assert float(temp[1]) == pytest.approx(expected, rel=1e-12)


def test_more_heat_gives_higher_temperature():
    p = ThermalParams()
    t = jnp.linspace(0.0, 1800.0, 181)
    cool = simulate_tyre_temperature(p, t, V100, FZ, 10.0, 15.0, 15.0)
    hot = simulate_tyre_temperature(p, t, V100, FZ, 200.0, 15.0, 15.0)
    assert bool(jnp.all(hot[1:] > cool[1:]))
    heavier = steady_state_temperature(p, 1.2 * FZ, V100, 0.0, 15.0)
    assert float(heavier) > float(steady_state_temperature(p, FZ, V100, 0.0, 15.0))


def test_convection_gradient_finite_at_standstill():
    g = jax.grad(lambda v: convective_conductance(ThermalParams(), v))(0.0)
    assert np.isfinite(float(g))


def test_temperature_gradients_match_finite_differences():
    t = jnp.linspace(0.0, 900.0, 91)
    speed = 20.0 + 5.0 * jnp.sin(t / 100.0)

    @jax.jit
    def final_temp(rr, c_th, h1, amb):
        p = ThermalParams(
            rolling_resistance=rr, heat_capacity_j_per_k=c_th, convection_speed_w_per_k=h1
        )
        return simulate_tyre_temperature(p, t, speed, FZ, 30.0, amb, 5.0)[-1]

    args = (0.011, 2.0e4, 3.0, 12.0)
    grads = jax.grad(final_temp, argnums=(0, 1, 2, 3))(*args)
    steps = (1e-7, 1.0, 1e-5, 1e-5)
    for i, (g, h) in enumerate(zip(grads, steps, strict=True)):

        def f(x, i=i):
            a = list(args)
            a[i] = x
            return float(final_temp(*a))

        fd = _central_difference(f, args[i], h)
        # float64 central differences: truncation ~h^2, round-off ~1e-16/h relative
        assert float(g) == pytest.approx(fd, rel=1e-6), i


def test_vmap_over_parameter_batch():
    rr = jnp.array([0.008, 0.010, 0.012])
    p = _stack([ThermalParams(rolling_resistance=float(r)) for r in rr])
    t = jnp.linspace(0.0, 600.0, 61)
    batched = jax.vmap(lambda q: simulate_tyre_temperature(q, t, V100, FZ, 0.0, 7.0, 7.0))(p)
    assert batched.shape == (3, 61)
    single = simulate_tyre_temperature(
        ThermalParams(rolling_resistance=float(rr[1])), t, V100, FZ, 0.0, 7.0, 7.0
    )
    np.testing.assert_allclose(batched[1], single, rtol=1e-13)
    assert bool(jnp.all(jnp.diff(batched[:, -1]) > 0))


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("rolling_resistance", 0.0),
        ("heat_capacity_j_per_k", -1.0),
        ("convection_still_w_per_k", 0.0),
        ("convection_speed_w_per_k", -0.1),
        ("convection_speed_exponent", 2.0),
        ("friction_heat_fraction", 1.5),
    ],
)
def test_bad_thermal_params_raise_naming_field(field, value):
    with pytest.raises(ValueError, match=field):
        ThermalParams(**{field: value})


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("sensitivity_per_k", -0.01),
        ("reference_stiffness", 0.0),
        ("stiffness_exponent", 3.0),
        ("reference_temperature_c", float("nan")),
    ],
)
def test_bad_compensation_params_raise_naming_field(field, value):
    with pytest.raises(ValueError, match=field):
        StiffnessTemperature(**{field: value})


def test_compensation_identity_at_reference_temperature():
    comp = StiffnessTemperature()
    c = jnp.array([25.0, 40.0, 60.0])
    np.testing.assert_allclose(stiffness_at_temperature(c, 20.0, comp), c, rtol=1e-15)
    np.testing.assert_allclose(compensate_stiffness(c, 20.0, comp), c, rtol=1e-12)


def test_compound_law_is_the_exponential_law_at_its_own_sensitivity():
    # stiffness_at_temperature is the fixed-kappa law (the tyre fit's) with kappa = beta(C_xr)
    comp = StiffnessTemperature(stiffness_exponent=0.7)
    c_xr = jnp.array([22.0, 40.0, 61.0])
    temp = jnp.array([-5.0, 35.0, 70.0])
    kappa = temperature_sensitivity(c_xr, comp)
    np.testing.assert_allclose(
        stiffness_at_temperature(c_xr, temp, comp),
        stiffness_with_sensitivity(c_xr, temp, kappa),
        rtol=1e-14,
    )
    # d ln C_x / dT = -kappa
    slope = jax.grad(lambda t: jnp.log(stiffness_with_sensitivity(40.0, t, 0.008)))(31.0)
    np.testing.assert_allclose(slope, -0.008, rtol=1e-12)


def test_inverse_of_forward_is_identity():
    c_xr = jnp.array([20.0, 29.0, 45.0, 60.0])[:, None]
    temp = jnp.array([-20.0, 7.0, 40.0, 70.0])[None, :]
    for q in (-1.0, 0.0, 1.0, 2.0):
        comp = StiffnessTemperature(sensitivity_per_k=0.006, stiffness_exponent=q)
        ok = compensation_is_invertible(c_xr, temp, comp)
        c_x = stiffness_at_temperature(c_xr, temp, comp)
        back = compensate_stiffness(c_x, temp, comp)
        expected = jnp.broadcast_to(c_xr, back.shape)
        np.testing.assert_allclose(back[ok], expected[ok], rtol=1e-12, err_msg=f"q={q}")
    # q = 2 at 60 / 70 °C: q beta dT = 1.35 > 1, the forward map folds over and is flagged
    assert not bool(ok[3, 3])
    assert int(ok.sum()) == 15


def test_compound_dependent_sensitivity():
    stiff_more = StiffnessTemperature(stiffness_exponent=1.0)
    soft_more = StiffnessTemperature(stiffness_exponent=-1.0)
    assert float(temperature_sensitivity(60.0, stiff_more)) > float(
        temperature_sensitivity(29.0, stiff_more)
    )
    assert float(temperature_sensitivity(29.0, soft_more)) > float(
        temperature_sensitivity(60.0, soft_more)
    )
    # warmer tyre -> lower stiffness
    assert float(stiffness_at_temperature(40.0, 50.0, stiff_more)) < 40.0


def test_compensation_gradients_match_finite_differences():
    comp = StiffnessTemperature()
    g = jax.grad(lambda c: compensate_stiffness(c, 45.0, comp))(40.0)
    fd = _central_difference(lambda c: float(compensate_stiffness(c, 45.0, comp)), 40.0, 1e-5)
    assert float(g) == pytest.approx(fd, rel=1e-7)
    # implicit-function check: dC_xr/dC_x = 1 / (dC_x/dC_xr)
    c_xr = compensate_stiffness(40.0, 45.0, comp)
    forward = jax.grad(lambda c: stiffness_at_temperature(c, 45.0, comp))(c_xr)
    assert float(g) == pytest.approx(1.0 / float(forward), rel=1e-10)


def test_compensation_vmaps_over_parameter_batch():
    comp = _stack([StiffnessTemperature(sensitivity_per_k=b) for b in (0.004, 0.006, 0.008)])
    out = jax.vmap(lambda cm: compensate_stiffness(35.0, 50.0, cm))(comp)
    assert out.shape == (3,)
    assert bool(jnp.all(jnp.diff(out) > 0))  # more sensitive -> larger correction back to 20 °C
    fwd = jax.vmap(lambda cm, c: stiffness_at_temperature(c, 50.0, cm))(comp, out)
    np.testing.assert_allclose(fwd, 35.0, rtol=1e-12)


def test_modules_are_pytrees_of_arrays():
    leaves = jax.tree_util.tree_leaves(eqx.filter(ThermalParams(), eqx.is_array_like))
    assert len(leaves) == 6
