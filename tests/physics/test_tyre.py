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
    brush_longitudinal_inverse_and_slope,
    brush_peak_slip,
    linear_force,
    magic_formula_inverse_and_slope,
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


def test_inverse_slope_equals_its_autodiff_derivative():
    rho = jnp.linspace(-0.89, 0.89, 179)
    slip, slope = brush_longitudinal_inverse_and_slope(rho, 30.0, 0.9)
    autodiff = jax.vmap(jax.grad(brush_longitudinal_inverse), (0, None, None))(rho, 30.0, 0.9)
    np.testing.assert_allclose(slip, brush_longitudinal_inverse(rho, 30.0, 0.9))
    np.testing.assert_allclose(slope, autodiff, rtol=1e-9)
    beyond = brush_longitudinal_inverse_and_slope(jnp.array([-0.95, 0.9, 1.2]), 30.0, 0.9)[1]
    np.testing.assert_array_equal(beyond, 0.0)


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


# --- audit of issue 2: lateral, combined, sliding extension, Magic Formula data and gradients ---


def _fd_grad(f, x, h=1e-6):
    steps = jnp.broadcast_to(jnp.asarray(h, dtype=float), x.shape)
    return jnp.array(
        [
            (f(x + hi * e) - f(x - hi * e)) / (2 * hi)
            for hi, e in zip(steps, jnp.eye(x.shape[0]), strict=True)
        ]
    )


def test_lateral_is_odd_c1_at_sliding_point_and_matches_fd():
    c_y, mu = 18.0, 0.9
    a = jnp.linspace(-0.4, 0.4, 81)
    np.testing.assert_allclose(brush_lateral(-a, c_y, mu), -brush_lateral(a, c_y, mu), atol=1e-15)
    a_peak = float(jnp.arctan(3 * mu / c_y))  # |θ tan α| = 1
    f = lambda x: brush_lateral(x, c_y, mu, 0.8)
    eps = 1e-7
    assert float(f(a_peak - eps)) == pytest.approx(float(f(a_peak + eps)), abs=1e-9)
    assert abs(float(jax.grad(f)(a_peak - eps)) - float(jax.grad(f)(a_peak + eps))) < 1e-5
    g = lambda p: brush_lateral(p[0], p[1], p[2], 0.8)
    for point in ([0.02, 18.0, 0.9], [-0.3, 25.0, 0.6], [0.0, 18.0, 0.9]):
        x = jnp.array(point)
        np.testing.assert_allclose(jax.grad(g)(x), _fd_grad(g, x), rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize(("c_x", "c_y"), [(30.0, 30.0), (30.0, 18.0)])
def test_combined_slopes_at_zero_are_c_x_and_c_y(c_x, c_y):
    jac = jax.jacfwd(lambda v: jnp.stack(brush_combined(v[0], v[1], c_x, c_y, 0.9)))(jnp.zeros(2))
    np.testing.assert_allclose(jac, jnp.diag(jnp.array([c_x, c_y])), atol=1e-12)


def test_combined_isotropic_resultant_depends_on_slip_magnitude_only():
    c, mu = 30.0, 0.9
    angles = jnp.linspace(0.0, 2 * jnp.pi, 13)
    for magnitude in (0.01, 0.05, 0.2):
        sx, ty = magnitude * jnp.cos(angles), magnitude * jnp.sin(angles)
        rx, ry = brush_combined(sx, jnp.arctan(ty), c, c, mu)
        np.testing.assert_allclose(
            jnp.hypot(rx, ry), jnp.abs(brush_longitudinal(magnitude, c, mu)), rtol=1e-12
        )
        # The force points along the slip vector (isotropic: no stiffness weighting).
        np.testing.assert_allclose(rx * ty - ry * sx, 0.0, atol=1e-12)


def test_combined_peak_is_mu_continuous_at_sliding_and_matches_fd():
    c_x, c_y, mu = 30.0, 18.0, 0.9
    direction = jnp.array([0.6, 0.8])
    # ψ = 1 where |(C_x σ, C_y tan α)| = 3μ along this direction.
    r_peak = float(3 * mu / jnp.hypot(c_x * direction[0], c_y * direction[1]))

    def resultant(r):
        rx, ry = brush_combined(r * direction[0], jnp.arctan(r * direction[1]), c_x, c_y, mu)
        return jnp.hypot(rx, ry)

    eps = 1e-7
    assert float(resultant(r_peak + eps)) == pytest.approx(mu, rel=1e-12)
    assert float(resultant(r_peak - eps)) == pytest.approx(mu, abs=1e-9)
    assert abs(float(jax.grad(resultant)(r_peak - eps))) < 1e-5
    assert abs(float(jax.grad(resultant)(r_peak + eps))) < 1e-5
    f = lambda p: sum(brush_combined(p[0], p[1], p[2], p[3], p[4]))
    for point in ([0.02, 0.01, 30.0, 18.0, 0.9], [-0.05, 0.2, 25.0, 20.0, 0.7]):
        x = jnp.array(point)
        np.testing.assert_allclose(jax.grad(f)(x), _fd_grad(f, x), rtol=1e-5, atol=1e-6)
    # Zero slip: finite gradient with respect to everything (the double-where).
    assert bool(jnp.all(jnp.isfinite(jax.grad(f)(jnp.array([0.0, 0.0, 30.0, 18.0, 0.9])))))


def test_sliding_extension_keeps_identities_and_falls_monotonically():
    c_x, mu, ratio = 30.0, 0.9, 0.7
    f = lambda s: brush_longitudinal(s, c_x, mu, ratio)
    assert float(jax.grad(f)(0.0)) == pytest.approx(c_x, rel=1e-12)
    s = jnp.linspace(0.0, 2.0, 20001)
    rho = f(s)
    assert float(rho.max()) == pytest.approx(mu, rel=1e-12)
    beyond = s > float(brush_peak_slip(c_x, mu))
    assert bool(jnp.all(jnp.diff(rho[beyond]) <= 1e-15))  # falls after the peak, never rises
    assert float(rho[-1]) == pytest.approx(ratio * mu, rel=1e-3)  # towards μ_s = r μ
    np.testing.assert_allclose(f(-s), -rho, atol=1e-15)  # still odd


def test_no_nan_parameter_gradient_at_zero_slip_and_at_the_transition():
    c_x, mu = 30.0, 0.9
    s_peak = float(brush_peak_slip(c_x, mu))
    f = lambda p, s: brush_longitudinal(s, p[0], p[1], p[2])
    p = jnp.array([c_x, mu, 0.8])
    for s in (0.0, s_peak, -s_peak, 1e-300):
        grad = jax.grad(f)(p, s)
        assert bool(jnp.all(jnp.isfinite(grad))), (s, grad)
    inv = lambda p, r: brush_longitudinal_inverse(r, p[0], p[1])
    for r in (0.0, mu, -mu, mu * (1 - 1e-13)):
        assert bool(jnp.all(jnp.isfinite(jax.grad(inv)(p, r)))), r


def test_brush_gradient_vmaps_over_parameter_batches():
    tyres = BrushTyre(c_x=C_X, c_y=C_X * 0.7, mu=MU, mu_slide_ratio=jnp.array([1.0, 0.8, 0.6]))
    slope = eqx.filter_vmap(lambda t: jax.grad(t.longitudinal)(0.0))(tyres)
    np.testing.assert_allclose(slope, C_X, rtol=1e-12)
    lat = eqx.filter_vmap(lambda t: jax.grad(t.lateral)(0.0))(tyres)
    np.testing.assert_allclose(lat, C_X * 0.7, rtol=1e-12)
    peaks = eqx.filter_vmap(lambda t: t.longitudinal(brush_peak_slip(t.c_x, t.mu)))(tyres)
    np.testing.assert_allclose(peaks, MU, rtol=1e-12)


def _measured_csv_rows():
    import csv

    from tyrebayes._resources import data_dir

    with open(data_dir() / "magic_formula_measured_fits.csv", newline="") as fh:
        return list(csv.DictReader(fh))


_CSV_TO_SET = {
    "205/60R15 91V": "pacejka_205_60R15",
    ("Goodyear 335/65R22.5 G275MSA (truck)", "40 psi"): "goodyear_truck_40psi",
    ("Goodyear 335/65R22.5 G275MSA (truck)", "95 psi"): "goodyear_truck_95psi",
    "185/80R14": "mf_185_80R14",
}


def test_magic_formula_sets_are_the_shipped_measured_numbers():
    """The coefficients in tyre.py equal tyrebayes/data/magic_formula_measured_fits.csv
    (the copy of ../shared/data/measured with its sources), including the load terms in 'note'."""
    rows = _measured_csv_rows()
    assert len(rows) == 4
    for row in rows:
        name = _CSV_TO_SET.get(row["tyre"]) or _CSV_TO_SET[(row["tyre"], row["pressure"])]
        mf = MagicFormulaLongitudinal.from_measured(name)
        for column in ("fnomin_n", "pkx1", "pdx1", "pcx1", "pex1"):
            assert getattr(mf, column) == pytest.approx(float(row[column]), rel=1e-12), column
        for token in row["note"].split():
            key, _, value = token.partition("=")
            if key.lower() in MagicFormulaLongitudinal.__dataclass_fields__:
                assert getattr(mf, key.lower()) == pytest.approx(float(value), rel=1e-12), key


@pytest.mark.parametrize(
    "name", ["pacejka_205_60R15", "goodyear_truck_40psi", "goodyear_truck_95psi", "mf_185_80R14"]
)
def test_magic_formula_gradients_match_fd_and_are_finite_at_zero(name):
    mf = MagicFormulaLongitudinal.from_measured(name)
    f = lambda x: magic_formula_longitudinal(x[0], x[1], mf)
    for slip in (0.0, 0.03, -0.2):
        x = jnp.array([slip, 1.2 * mf.fnomin_n])
        analytic = jax.grad(f)(x)
        assert bool(jnp.all(jnp.isfinite(analytic)))
        np.testing.assert_allclose(
            analytic, _fd_grad(f, x, h=jnp.array([1e-7, 1e-2])), rtol=1e-5, atol=1e-9
        )
    s = jnp.linspace(-0.5, 0.5, 101)
    np.testing.assert_allclose(
        magic_formula_longitudinal(-s, mf.fnomin_n, mf),
        -magic_formula_longitudinal(s, mf.fnomin_n, mf),
        atol=1e-14,
    )


def test_magic_formula_vmaps_over_measured_parameter_sets():
    names = ["pacejka_205_60R15", "goodyear_truck_40psi", "goodyear_truck_95psi", "mf_185_80R14"]
    sets = [MagicFormulaLongitudinal.from_measured(n) for n in names]
    batch = jax.tree_util.tree_map(lambda *xs: jnp.array(xs), *sets)
    fz = jnp.array([m.fnomin_n for m in sets])
    slope = jax.vmap(lambda m, f: jax.grad(magic_formula_longitudinal)(0.0, f, m))(batch, fz)
    np.testing.assert_allclose(slope, [m.pkx1 for m in sets], rtol=1e-10)


@pytest.mark.parametrize(
    ("kwargs", "field", "value"),
    [
        (dict(c_x=-1.0, c_y=20.0, mu=1.0), "c_x", "-1.0"),
        (dict(c_x=0.0, c_y=20.0, mu=1.0), "c_x", "0.0"),
        (dict(c_x=30.0, c_y=-2.0, mu=1.0), "c_y", "-2.0"),
        (dict(c_x=30.0, c_y=20.0, mu=-0.1), "mu", "-0.1"),
        (dict(c_x=30.0, c_y=20.0, mu=float("nan")), "mu", "nan"),
    ],
)
def test_bad_brush_parameters_name_field_and_value(kwargs, field, value):
    with pytest.raises(ValueError, match=rf"\.{field}: .*got {value}"):
        BrushTyre(**kwargs)


@pytest.mark.parametrize(("field", "value"), [("pkx1", -3.0), ("pdx1", 0.0), ("fnomin_n", -1.0)])
def test_bad_magic_formula_parameters_name_field_and_value(field, value):
    fields = dict(fnomin_n=4000.0, pkx1=21.5, pdx1=1.2, pcx1=1.6, pex1=0.3) | {field: value}
    with pytest.raises(ValueError, match=rf"{field}: .*got {value}"):
        MagicFormulaLongitudinal(**fields)


def test_shaped_inverse_is_the_brush_at_shape_one_and_its_slope_is_the_derivative():
    import jax
    import jax.numpy as jnp

    from tyrebayes.physics.tyre import (
        brush_longitudinal_inverse_and_slope,
        shaped_longitudinal_inverse_and_slope,
    )

    rho = jnp.linspace(-0.95, 0.95, 39)
    brush = brush_longitudinal_inverse_and_slope(rho, 35.0, 1.0)
    shaped = shaped_longitudinal_inverse_and_slope(rho, 35.0, 1.0, 1.0)
    np.testing.assert_allclose(shaped[0], brush[0], rtol=1e-12)
    np.testing.assert_allclose(shaped[1], brush[1], rtol=1e-10)
    for p in (0.8, 2.0, 2.7):
        slip, slope = shaped_longitudinal_inverse_and_slope(rho, 35.0, 1.0, p)
        autodiff = jax.vmap(
            jax.grad(lambda r, p=p: shaped_longitudinal_inverse_and_slope(r, 35.0, 1.0, p)[0])
        )(rho)
        np.testing.assert_allclose(slope, autodiff, rtol=1e-9)
        # slope 1/C_x at zero force, the peak slip 3μ/C_x at the peak, monotone in between
        assert float(shaped_longitudinal_inverse_and_slope(1e-9, 35.0, 1.0, p)[1]) == pytest.approx(
            1 / 35.0
        )
        assert float(shaped_longitudinal_inverse_and_slope(1.0, 35.0, 1.0, p)[0]) == pytest.approx(
            3 / 35.0
        )
        assert np.all(np.diff(np.asarray(slip)) > 0)
    # A later bend: at 30 % of the peak, p = 2 needs less slip than the brush.
    later = shaped_longitudinal_inverse_and_slope(0.3, 35.0, 1.0, 2.0)[0]
    assert float(later) < float(brush_longitudinal_inverse_and_slope(0.3, 35.0, 1.0)[0])


# --- The Magic Formula inverse (the per-tyre model's default curve) -------------------------
# Shapes spanning the shipped database's car/SUV sets (C 1.32-1.84, E -4.1-0.63) and beyond.
MF_SHAPES = [(1.32, -0.32), (1.58, 0.11), (1.84, 0.63), (1.42, -4.12), (1.1, 0.9)]


@pytest.mark.parametrize("shape, curvature", MF_SHAPES)
def test_magic_formula_inverse_inverts_the_forward_curve(shape, curvature):
    mf = MagicFormulaLongitudinal(4000.0, pkx1=40.0, pdx1=0.9, pcx1=shape, pex1=curvature)
    rho = jnp.linspace(-0.89, 0.89, 41)
    slip, slope = magic_formula_inverse_and_slope(rho, 40.0, 0.9, shape, curvature)
    np.testing.assert_allclose(magic_formula_longitudinal(slip, 4000.0, mf), rho, atol=1e-12)
    # dσ/dρ is the reciprocal of the forward slope (central differences, x64).
    h = 1e-7
    forward = (
        magic_formula_longitudinal(slip + h, 4000.0, mf)
        - magic_formula_longitudinal(slip - h, 4000.0, mf)
    ) / (2 * h)
    np.testing.assert_allclose(slope * forward, 1.0, rtol=1e-6)


def test_magic_formula_inverse_identities():
    # Slope 1/C_x at zero force, odd symmetry, the peak slip beyond the peak with slope 0.
    slope0 = jax.grad(lambda r: magic_formula_inverse_and_slope(r, 35.0, 1.0, 1.6, 0.2)[0])(0.0)
    assert float(slope0) == pytest.approx(1.0 / 35.0, rel=1e-12)
    s_pos, _ = magic_formula_inverse_and_slope(0.4, 35.0, 1.0, 1.6, 0.2)
    s_neg, _ = magic_formula_inverse_and_slope(-0.4, 35.0, 1.0, 1.6, 0.2)
    assert float(s_neg) == pytest.approx(-float(s_pos), rel=1e-12)
    at_peak, slope_at_peak = magic_formula_inverse_and_slope(1.0, 35.0, 1.0, 1.6, 0.2)
    beyond, slope_beyond = magic_formula_inverse_and_slope(1.3, 35.0, 1.0, 1.6, 0.2)
    mf = MagicFormulaLongitudinal(4000.0, pkx1=35.0, pdx1=1.0, pcx1=1.6, pex1=0.2)
    assert float(magic_formula_longitudinal(at_peak, 4000.0, mf)) == pytest.approx(1.0, abs=1e-12)
    assert float(beyond) == pytest.approx(float(at_peak), rel=1e-12)
    assert float(slope_at_peak) == 0.0 and float(slope_beyond) == 0.0


def test_magic_formula_inverse_gradients_and_hessian_are_finite_and_match_fd():
    def slip_of(p):
        return magic_formula_inverse_and_slope(p[0], p[1], p[2], p[3], p[4])[0]

    point = jnp.array([0.3, 40.0, 0.9, 1.6, 0.2])
    grad = jax.grad(slip_of)(point)
    h = 1e-6
    fd = jnp.array(
        [(slip_of(point.at[i].add(h)) - slip_of(point.at[i].add(-h))) / (2 * h) for i in range(5)]
    )
    np.testing.assert_allclose(grad, fd, rtol=1e-6, atol=1e-12)
    # Beyond the peak (ABS windows' forces): no NaN in gradients or second derivatives.
    for rho in (0.0, 0.95, -1.2):
        p = point.at[0].set(rho)
        assert bool(jnp.all(jnp.isfinite(jax.grad(slip_of)(p))))
        assert bool(jnp.all(jnp.isfinite(jax.hessian(slip_of)(p))))
