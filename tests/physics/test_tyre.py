"""Physics identities of the tyre force models (float64, see conftest)."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.physics.tyre import (
    BrushTyre,
    MagicFormulaLongitudinal,
    brush_combined,
    brush_lateral,
    brush_longitudinal,
    brush_longitudinal_inverse,
    brush_peak_slip,
    linear_force,
    magic_formula_longitudinal,
)

C_X = jnp.array([20.0, 35.0, 60.0])
MU = jnp.array([0.3, 0.8, 1.2])


def test_linear_force_is_stiffness_times_slip():
    assert float(linear_force(0.02, 30.0)) == pytest.approx(0.6)


def test_brush_slope_at_zero_is_c_x():
    slope = jax.vmap(jax.grad(brush_longitudinal), in_axes=(None, 0, 0))(0.0, C_X, MU)
    np.testing.assert_allclose(slope, C_X, rtol=1e-12)


def test_brush_peak_is_mu_and_reached_at_peak_slip():
    slips = jnp.linspace(0.0, 1.0, 20001)
    for c_x, mu in zip(C_X, MU, strict=True):
        rho = brush_longitudinal(slips, c_x, mu)
        assert float(rho.max()) == pytest.approx(float(mu), rel=1e-12)
        first_peak = float(slips[jnp.argmax(rho >= mu * (1 - 1e-9))])
        assert first_peak == pytest.approx(float(brush_peak_slip(c_x, mu)), abs=1e-3)


def test_brush_is_odd_in_slip():
    s = jnp.linspace(-0.5, 0.5, 101)
    np.testing.assert_allclose(brush_longitudinal(-s, 30.0, 0.9), -brush_longitudinal(s, 30.0, 0.9))


@pytest.mark.parametrize("ratio", [1.0, 0.7])
def test_brush_continuous_with_continuous_slope_at_sliding_point(ratio):
    c_x, mu = 30.0, 0.9
    s_peak = float(brush_peak_slip(c_x, mu))
    eps = 1e-7
    f = lambda s: brush_longitudinal(s, c_x, mu, ratio)
    assert float(f(s_peak - eps)) == pytest.approx(float(f(s_peak + eps)), abs=1e-9)
    g = jax.grad(f)
    assert float(g(s_peak - eps)) == pytest.approx(float(g(s_peak + eps)), abs=1e-5)
    assert abs(float(g(s_peak - eps))) < 1e-5  # zero slope at the peak


def test_sliding_friction_ratio_makes_curve_fall_after_peak():
    rho_far = brush_longitudinal(1.0, 30.0, 1.0, mu_slide_ratio=0.7)
    assert 0.7 <= float(rho_far) < 0.75


def test_gradients_match_finite_differences():
    def f(params):
        s, c, m = params
        return brush_longitudinal(s, c, m, 0.8)

    for point in ([0.013, 30.0, 0.9], [-0.05, 25.0, 0.6], [0.2, 40.0, 1.0], [0.0, 30.0, 1.0]):
        x = jnp.array(point)
        analytic = jax.grad(f)(x)
        h = 1e-6
        numeric = jnp.array([(f(x + h * e) - f(x - h * e)) / (2 * h) for e in jnp.eye(3)])
        np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-6)


def test_no_nan_gradient_anywhere():
    s = jnp.concatenate([jnp.linspace(-0.6, 0.6, 241), jnp.array([0.0, 0.1, -0.1])])
    for fn in (
        lambda x: brush_longitudinal(x, 30.0, 1.0, 0.8),
        lambda x: brush_lateral(x, 20.0, 1.0),
        lambda x: sum(brush_combined(x, 0.3 * x, 30.0, 20.0, 1.0)),
        lambda x: brush_longitudinal_inverse(x, 30.0, 1.0),
    ):
        assert bool(jnp.all(jnp.isfinite(jax.vmap(jax.grad(fn))(s))))


def test_lateral_slope_is_c_y_and_peak_mu():
    assert float(jax.grad(brush_lateral)(0.0, 18.0, 0.9)) == pytest.approx(18.0)
    assert float(brush_lateral(0.5, 18.0, 0.9)) == pytest.approx(0.9)


def test_combined_reduces_to_pure_slip_and_respects_friction_circle():
    s = jnp.linspace(-0.3, 0.3, 61)
    rx, ry = brush_combined(s, 0.0, 30.0, 20.0, 0.9)
    np.testing.assert_allclose(rx, brush_longitudinal(s, 30.0, 0.9), atol=1e-12)
    np.testing.assert_allclose(ry, 0.0, atol=1e-15)
    rx, ry = brush_combined(0.0, s, 30.0, 20.0, 0.9)
    np.testing.assert_allclose(ry, brush_lateral(s, 20.0, 0.9), atol=1e-12)
    grid = jnp.linspace(-0.4, 0.4, 41)
    rx, ry = brush_combined(grid[:, None], grid[None, :], 30.0, 20.0, 0.9)
    assert float(jnp.max(jnp.hypot(rx, ry))) <= 0.9 + 1e-12


def test_inverse_of_forward_is_identity_in_adhesion():
    rho = jnp.linspace(-0.89, 0.89, 179)
    slip = brush_longitudinal_inverse(rho, 30.0, 0.9)
    np.testing.assert_allclose(brush_longitudinal(slip, 30.0, 0.9), rho, atol=1e-12)
    s = jnp.linspace(-0.08, 0.08, 81)  # below the peak slip 0.09
    np.testing.assert_allclose(
        brush_longitudinal_inverse(brush_longitudinal(s, 30.0, 0.9), 30.0, 0.9), s, atol=1e-9
    )
    assert float(jax.grad(brush_longitudinal_inverse)(0.0, 30.0, 0.9)) == pytest.approx(1 / 30)


def test_everything_vmaps_over_parameter_sets():
    tyres = BrushTyre(c_x=C_X, c_y=C_X * 0.7, mu=MU)
    rho = eqx.filter_vmap(lambda t: t.longitudinal(0.01))(tyres)
    assert rho.shape == (3,)
    np.testing.assert_allclose(rho, brush_longitudinal(0.01, C_X, MU))


@pytest.mark.parametrize(
    "name", ["pacejka_205_60R15", "goodyear_truck_40psi", "goodyear_truck_95psi", "mf_185_80R14"]
)
def test_magic_formula_slope_at_zero_is_pkx1_at_nominal_load(name):
    mf = MagicFormulaLongitudinal.from_measured(name)
    slope = jax.grad(magic_formula_longitudinal)(0.0, mf.fnomin_n, mf)
    assert float(slope) == pytest.approx(mf.pkx1, rel=1e-10)


def test_magic_formula_peak_is_pdx1_and_falls_after():
    mf = MagicFormulaLongitudinal.from_measured("pacejka_205_60R15")
    s = jnp.linspace(0, 1, 10001)
    rho = magic_formula_longitudinal(s, mf.fnomin_n, mf)
    assert float(rho.max()) == pytest.approx(1.210, rel=1e-6)
    assert float(rho[-1]) < float(rho.max())  # real tyres fall after the peak


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        (dict(c_x=-1.0, c_y=20.0, mu=1.0), "c_x"),
        (dict(c_x=30.0, c_y=0.0, mu=1.0), "c_y"),
        (dict(c_x=30.0, c_y=20.0, mu=0.0), "mu"),
        (dict(c_x=30.0, c_y=20.0, mu=1.0, mu_slide_ratio=1.5), "mu_slide_ratio"),
    ],
)
def test_bad_parameters_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        BrushTyre(**kwargs)


def test_unknown_magic_formula_set():
    with pytest.raises(ValueError, match="nope"):
        MagicFormulaLongitudinal.from_measured("nope")
