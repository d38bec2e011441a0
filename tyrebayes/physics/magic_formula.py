"""The Magic Formula pure longitudinal tyre curve (Pacejka 2006, 4.E9–E18) and its inverse.

Re-exported by :mod:`tyrebayes.physics.tyre`, with the linear and brush models.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..internal.validation import check_positive

#: A scalar or array argument (the same alias as :mod:`tyrebayes.physics.tyre`'s).
Scalarish = Float[ArrayLike, "..."]

# Measured Magic Formula fits (copied from ../shared/data/measured/magic_formula_measured_fits.csv;
# coefficients the source does not give are 0, the MF 5.2 default).
_MEASURED_MF: dict[str, dict[str, float]] = {
    # Pacejka, Tire and Vehicle Dynamics (2006), Table A3.1, 205/60R15 91V at 2.2 bar.
    "pacejka_205_60R15": dict(
        fnomin_n=4000.0,
        pkx1=21.51,
        pkx2=-0.163,
        pkx3=0.245,
        pdx1=1.210,
        pdx2=-0.037,
        pcx1=1.685,
        pex1=0.344,
    ),
    # Goodyear 335/65R22.5 G275MSA truck tyre, Calspan rig fit, 40 psi (projectchrono FEDA .tir).
    "goodyear_truck_40psi": dict(
        fnomin_n=16929.0,
        pkx1=8.5834,
        pkx2=1.0235e-4,
        pkx3=-6.6015e-2,
        pdx1=0.98412,
        pdx2=-4.3414e-2,
        pcx1=1.4,
        pex1=-6.9271,
        pex2=-4.498,
        pex3=1.4378e-2,
    ),
    # The same truck tyre at 95 psi (only PKX1, PDX1, PCX1, PEX1 published in the table).
    "goodyear_truck_95psi": dict(
        fnomin_n=16929.0,
        pkx1=6.3425,
        pdx1=0.84003,
        pcx1=1.4,
        pex1=-4.5309,
    ),
    # 185/80R14 of unclear origin (projectchrono VW microbus); plausibility only.
    "mf_185_80R14": dict(fnomin_n=3800.0, pkx1=19.733, pdx1=1.09, pcx1=1.5587, pex1=0.27403),
}


class MagicFormulaLongitudinal(eqx.Module):
    """Magic Formula (MF 5.2) pure longitudinal slip coefficients, scaling factors 1, no camber.

    Fields are the ``.tir`` names: ``fnomin_n`` nominal load [N]; PKX1–3 slip stiffness Kx/Fz and
    its load dependence; PDX1–2 peak friction and its load dependence; PCX1 shape; PEX1–3
    curvature. Use :meth:`from_measured` for the rig-measured sets shipped with the package.

    Parameters
    ----------
    fnomin_n : float
        Nominal load F_z0 [N].
    pkx1, pkx2, pkx3 : float
        Slip stiffness K_x/F_z at nominal load [-], and its load dependence.
    pdx1, pdx2 : float
        Peak friction μ at nominal load [-], and its load dependence.
    pcx1 : float
        Shape factor C [-].
    pex1, pex2, pex3 : float
        Curvature E [-], and its load dependence.

    Examples
    --------
    >>> mf = MagicFormulaLongitudinal.from_measured("pacejka_205_60R15")
    >>> mf.fnomin_n, mf.pdx1
    (4000.0, 1.21)
    """

    fnomin_n: float
    pkx1: float
    pdx1: float
    pcx1: float
    pex1: float
    pkx2: float = 0.0
    pkx3: float = 0.0
    pdx2: float = 0.0
    pex2: float = 0.0
    pex3: float = 0.0

    def __check_init__(self):
        check_positive("MagicFormulaLongitudinal", "fnomin_n", self.fnomin_n)
        check_positive("MagicFormulaLongitudinal", "pkx1", self.pkx1)
        check_positive("MagicFormulaLongitudinal", "pdx1", self.pdx1)
        check_positive("MagicFormulaLongitudinal", "pcx1", self.pcx1)

    @classmethod
    def from_measured(cls, name: str) -> MagicFormulaLongitudinal:
        """One of the measured sets: ``pacejka_205_60R15``, ``goodyear_truck_40psi``,
        ``goodyear_truck_95psi``, ``mf_185_80R14``."""
        if name not in _MEASURED_MF:
            raise ValueError(
                f"Magic Formula set: expected one of {sorted(_MEASURED_MF)}, got {name!r}"
            )
        return cls(**_MEASURED_MF[name])


def magic_formula_longitudinal(
    slip: Scalarish, fz_n: Scalarish, mf: MagicFormulaLongitudinal
) -> Float[Array, "..."]:
    """Normalised longitudinal force ρ_x = F_x/F_z of the Magic Formula (Pacejka 2006, 4.E9–E18).

    dfz = (F_z − F_z0)/F_z0; D = (PDX1 + PDX2 dfz) F_z; C = PCX1;
    E = PEX1 + PEX2 dfz + PEX3 dfz² (capped at 1); K = F_z (PKX1 + PKX2 dfz) exp(PKX3 dfz);
    B = K/(C D); F_x = D sin(C atan(Bσ − E(Bσ − atan Bσ))). The slope at zero is K/F_z, i.e. PKX1 at
    nominal load.

    Examples
    --------
    >>> mf = MagicFormulaLongitudinal.from_measured("pacejka_205_60R15")
    >>> round(float(magic_formula_longitudinal(1e-6, 4000.0, mf) / 1e-6), 2)
    21.51
    """
    slip, fz = jnp.asarray(slip), jnp.asarray(fz_n)
    dfz = (fz - mf.fnomin_n) / mf.fnomin_n
    mu = mf.pdx1 + mf.pdx2 * dfz
    shape = mf.pcx1
    curvature = jnp.minimum(mf.pex1 + mf.pex2 * dfz + mf.pex3 * dfz**2, 1.0)
    stiffness = (mf.pkx1 + mf.pkx2 * dfz) * jnp.exp(mf.pkx3 * dfz)  # K_x / F_z
    b = stiffness / (shape * mu)
    bs = b * slip
    return mu * jnp.sin(shape * jnp.arctan(bs - curvature * (bs - jnp.arctan(bs))))


# Newton steps of the Magic Formula inverse: h(x) = (1 − E)x + E atan(x) is monotone for E < 1
# and concave (E > 0) or convex (E < 0) on x > 0, so Newton from x = t converges monotonically;
# eight steps reach float64 round-off for peak slips up to tan(π/(2·1.1)) ≈ 7 (C ≥ 1.1).
_MF_NEWTON_STEPS = 8


@jax.custom_jvp
def _magic_formula_root(t, curvature):
    """x with (1 − E)x + E atan x = t, by Newton's method from x = t (``_MF_NEWTON_STEPS``)."""
    x = t
    for _ in range(_MF_NEWTON_STEPS):
        h = (1.0 - curvature) * x + curvature * jnp.arctan(x) - t
        x = x - h / (1.0 - curvature + curvature / (1.0 + x**2))
    return x


@_magic_formula_root.defjvp
def _magic_formula_root_jvp(primals, tangents):
    # Implicit differentiation of h(x; E) = t: dx = (dt − ∂h/∂E dE)/h′(x). Derivatives then cost
    # one evaluation of h′ instead of a pass through the unrolled Newton steps, and higher ones
    # (the Laplace Hessian's) follow from differentiating this rule, which calls the root again.
    t, curvature = primals
    dt, dcurvature = tangents
    x = _magic_formula_root(t, curvature)
    slope = 1.0 - curvature + curvature / (1.0 + x**2)
    return x, (dt - (jnp.arctan(x) - x) * dcurvature) / slope


def magic_formula_inverse_and_slope(
    rho: Scalarish, c_x: Scalarish, mu: Scalarish, shape: Scalarish, curvature: Scalarish
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """Slip of a force on a Magic Formula curve in adhesion, and dσ/dρ (pure longitudinal slip).

    The curve is ρ = μ sin(C atan(Bσ − E(Bσ − atan Bσ))) with B = C_x/(C μ) (Pacejka 2006,
    4.E9–E18 at one load; slope C_x at zero, peak μ). With y = ρ/μ and x = Bσ the inverse solves
    (1 − E)x + E atan x = t, t = tan(asin(y)/C), by Newton's method (``_MF_NEWTON_STEPS``),
    differentiated implicitly, to any order. dρ/dσ = C_x √(1 − y²) h′(x)/(1 + t²)
    with h′(x) = 1 − E + E/(1 + x²). Near zero the curve departs from its tangent with a cubic
    term: ρ ≈ C_x σ (1 − x²((1 + E)/3 + C²/6)), where the brush model's departure is quadratic
    (thesis eq. 3.3–3.4); that is why a brush fit to such a tyre reads its straight start as a
    higher C_x. Forces at or beyond the peak map to the peak slip with slope 0, as in
    :func:`brush_longitudinal_inverse_and_slope`.

    Parameters
    ----------
    rho : array
        Normalised longitudinal force ρ_x = F_x/F_z [-].
    c_x : array
        Slip stiffness, the slope at zero slip [-].
    mu : array
        Peak of the curve μ_max [-].
    shape : array
        Magic Formula shape factor C (> 1 for a curve with a peak) [-].
    curvature : array
        Magic Formula curvature factor E (< 1) [-].

    Examples
    --------
    >>> mf = MagicFormulaLongitudinal(4000.0, pkx1=30.0, pdx1=1.0, pcx1=1.6, pex1=0.3)
    >>> slip, _ = magic_formula_inverse_and_slope(0.5, 30.0, 1.0, 1.6, 0.3)
    >>> round(float(magic_formula_longitudinal(slip, 4000.0, mf)), 6)
    0.5
    """
    rho, c_x, mu = jnp.asarray(rho), jnp.asarray(c_x), jnp.asarray(mu)
    shape, curvature = jnp.asarray(shape), jnp.asarray(curvature)
    # Signed throughout (every step is odd in y), so that the derivative at ρ = 0 is right.
    y = rho / mu
    inside = jnp.abs(y) < 1.0
    # At and beyond the peak: the peak slip, t = tan(π/(2C)). The double-where keeps asin away
    # from ±1 in the branch not taken, whose infinite derivative would give NaN gradients.
    y_in = jnp.where(inside, y, 0.5 * jnp.sign(y))
    t = jnp.where(
        inside,
        jnp.tan(jnp.arcsin(y_in) / shape),
        jnp.sign(y) * jnp.tan(0.5 * jnp.pi / shape),
    )
    t, curvature = jnp.broadcast_arrays(t, curvature)
    x = _magic_formula_root(t, curvature)
    b = c_x / (shape * mu)
    slip = x / b
    dh = 1.0 - curvature + curvature / (1.0 + x**2)
    force_slope = c_x * jnp.sqrt(jnp.where(inside, 1.0 - y_in**2, 1.0)) * dh / (1.0 + t**2)
    slope = jnp.where(inside, 1.0 / force_slope, 0.0)
    return slip, slope


def magic_formula_inverse_series(shape, curvature):
    """The Magic Formula inverse's odd series at zero: σ = (ρ/C_x)(1 + k₃ y² + k₅ y⁴ + …), y = ρ/μ.

    With the curve y = sin(C atan(Bσ − E(Bσ − atan Bσ))) (slope 1, peak 1) expanded as
    y = s − a s³ + b s⁵ in s = C_x σ/μ: a = (1 + E)/(3C²) + 1/6 and
    b = (8E + 3)/(15C⁴) + (1 + E)/(6C²) + 1/120, so the inverse has k₃ = a and k₅ = 3a² − b.

    Parameters
    ----------
    shape, curvature : float or array
        The curve's C and E.

    Returns
    -------
    tuple of arrays
        k₃ and k₅.

    Examples
    --------
    At 60 % of the peak, the series to third and to fifth order against the curve's inverse:

    >>> k3, k5 = magic_formula_inverse_series(1.344, -0.631)
    >>> y = 0.6
    >>> exact = float(magic_formula_inverse_and_slope(y, 1.0, 1.0, 1.344, -0.631)[0])
    >>> third, fifth = y * (1 + k3 * y**2), y * (1 + k3 * y**2 + k5 * y**4)
    >>> round(third / exact - 1, 3), round(fifth / exact - 1, 3)
    (-0.025, -0.006)
    """
    c2 = shape * shape
    a = (1.0 + curvature) / (3.0 * c2) + 1.0 / 6.0
    b = (8.0 * curvature + 3.0) / (15.0 * c2 * c2) + (1.0 + curvature) / (6.0 * c2) + 1.0 / 120.0
    return a, 3.0 * a * a - b
