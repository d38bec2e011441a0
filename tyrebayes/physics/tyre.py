"""Normalised tyre force models: linear slip, brush (parabolic pressure) and Magic Formula.

All functions are pure JAX, broadcast over their arguments and are safe under ``jit``, ``vmap`` and
``grad`` (no NaN gradient at zero slip or at the adhesion/sliding transition).

Conventions (thesis chapter 2.2): longitudinal slip σ_x = (R_e Ω − V_x)/V_x (eq. 2.1), positive in
traction; side-slip α in rad; forces are normalised by the normal load, ρ = F/F_z (eq. 3.2, 5.3).
The brush model with parabolic pressure has slope C at zero slip (eq. 3.4, 5.5) and peak μ
(eq. 3.3).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from ..internal.validation import check_in_range, check_positive
from .magic_formula import MagicFormulaLongitudinal as MagicFormulaLongitudinal
from .magic_formula import magic_formula_inverse_and_slope as magic_formula_inverse_and_slope
from .magic_formula import magic_formula_longitudinal as magic_formula_longitudinal

Scalarish = Float[ArrayLike, "..."]


def linear_force(slip: Scalarish, stiffness: Scalarish) -> Float[Array, "..."]:
    """Linear slip model ρ = C σ (thesis eq. 4.27 read forwards).

    Parameters
    ----------
    slip : array_like
        Longitudinal slip σ_x [-] (or side-slip α [rad]).
    stiffness : array_like
        Normalised slip stiffness C [-] (or [1/rad]).

    Returns
    -------
    Array
        Normalised force ρ [-].

    Examples
    --------
    >>> float(linear_force(0.01, 30.0))
    0.3
    """
    return jnp.asarray(stiffness) * jnp.asarray(slip)


def _brush_shape(u: Array, mu: Array, mu_slide_ratio: Array, slide_width: float) -> Array:
    """Brush force for the normalised slip u = θσ, θ = C/(3μ).

    Adhesion (|u| < 1): ρ = μ(3u − 3u|u| + u³), whose slope is 3μθ(1 − |u|)², so the curve and its
    first derivative are continuous at |u| = 1 where ρ = μ. Sliding (|u| ≥ 1): ρ = μ, or with a
    sliding friction μ_s = r μ < μ an empirical fall μ − (μ − μ_s)(1 − exp(−((|u| − 1)/w)²)) that
    keeps the derivative continuous (zero) at the peak.
    """
    abs_u = jnp.abs(u)
    adhesion = mu * (3.0 * u - 3.0 * u * abs_u + u**3)
    excess = (abs_u - 1.0) / slide_width
    fall = (1.0 - mu_slide_ratio) * (1.0 - jnp.exp(-(excess**2)))
    sliding = jnp.sign(u) * mu * (1.0 - fall)
    return jnp.where(abs_u < 1.0, adhesion, sliding)


def brush_longitudinal(
    slip: Scalarish,
    c_x: Scalarish,
    mu: Scalarish,
    mu_slide_ratio: Scalarish = 1.0,
    slide_width: float = 2.0,
) -> Float[Array, "..."]:
    """Longitudinal brush model with parabolic pressure distribution.

    With θ = C_x/(3μ): ρ_x = 3μθσ(1 − |θσ| + (θσ)²/3) for |θσ| < 1 and μ·sign(σ) beyond
    (the brush model of the thesis' references [7, 14]; slope C_x at zero, eq. 3.4; peak μ,
    eq. 3.3).

    Parameters
    ----------
    slip : array_like
        Longitudinal slip σ_x [-], positive in traction.
    c_x : array_like
        Longitudinal slip stiffness C_x [-] (typically 20–60 for car tyres).
    mu : array_like
        Friction potential μ_max [-] (> 0).
    mu_slide_ratio : array_like, optional
        Sliding-to-peak friction ratio r ∈ (0, 1]; r < 1 lets the curve fall after its peak
        towards r·μ (an empirical, C¹ extension; 1 gives the classical brush model).
    slide_width : float, optional
        Width of that fall in units of the peak slip (static).

    Returns
    -------
    Array
        Normalised longitudinal force ρ_x = F_x/F_z [-].

    Examples
    --------
    >>> round(float(brush_longitudinal(1e-4, 30.0, 1.0) / 1e-4), 3)
    29.97
    >>> float(brush_longitudinal(0.5, 30.0, 1.0))
    1.0
    """
    c_x, mu = jnp.asarray(c_x), jnp.asarray(mu)
    u = c_x * jnp.asarray(slip) / (3.0 * mu)
    return _brush_shape(u, mu, jnp.asarray(mu_slide_ratio), slide_width)


def brush_lateral(
    alpha: Scalarish,
    c_y: Scalarish,
    mu: Scalarish,
    mu_slide_ratio: Scalarish = 1.0,
    slide_width: float = 2.0,
) -> Float[Array, "..."]:
    """Lateral brush model: the longitudinal shape in tan(α) with cornering stiffness C_y.

    ρ_y(α) has slope C_y [1/rad] at α = 0 (eq. 5.5) and peak μ (eq. 5.4). Positive α gives
    positive ρ_y (the sign convention of the single-track model used here: force opposes slip
    velocity, so callers pass α = −(v_y + l ψ̇)/v_x + δ as needed).

    Examples
    --------
    >>> round(float(brush_lateral(1e-4, 20.0, 1.0) / 1e-4), 2)
    19.99
    """
    c_y, mu = jnp.asarray(c_y), jnp.asarray(mu)
    u = c_y * jnp.tan(jnp.asarray(alpha)) / (3.0 * mu)
    return _brush_shape(u, mu, jnp.asarray(mu_slide_ratio), slide_width)


def brush_combined(
    slip: Scalarish, alpha: Scalarish, c_x: Scalarish, c_y: Scalarish, mu: Scalarish
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """Combined-slip brush model with an isotropic friction circle and C_x ≠ C_y allowed.

    With ψ = √((C_x σ)² + (C_y tan α)²)/(3μ) the resultant is ρ = μ(3ψ − 3ψ² + ψ³) for ψ < 1 and μ
    beyond, directed along the stiffness-weighted slip vector (C_x σ, C_y tan α). Pure slip reduces
    to :func:`brush_longitudinal` and :func:`brush_lateral`.

    Returns
    -------
    (rho_x, rho_y) : tuple of Array
        Normalised longitudinal and lateral forces [-]; √(ρ_x² + ρ_y²) ≤ μ (eq. 3.1).

    Examples
    --------
    >>> rx, ry = brush_combined(0.5, 0.5, 30.0, 20.0, 1.0)
    >>> round(float(jnp.hypot(rx, ry)), 6)
    1.0
    """
    mu = jnp.asarray(mu)
    sx = jnp.asarray(c_x) * jnp.asarray(slip)
    sy = jnp.asarray(c_y) * jnp.tan(jnp.asarray(alpha))
    squared = sx**2 + sy**2
    nonzero = squared > 0.0
    # sqrt has an infinite derivative at 0: double-where keeps the gradient finite at zero slip.
    norm = jnp.where(nonzero, jnp.sqrt(jnp.where(nonzero, squared, 1.0)), 0.0)
    psi = norm / (3.0 * mu)
    in_adhesion = psi < 1.0
    # ρ/ψ·(1/3μ) in adhesion is a polynomial: no division by ψ near zero (double-where trick).
    adhesion_gain = (3.0 - 3.0 * psi + psi**2) / 3.0
    psi_safe = jnp.where(in_adhesion, 1.0, psi)
    sliding_gain = 1.0 / (3.0 * psi_safe)
    gain = jnp.where(in_adhesion, adhesion_gain, sliding_gain)
    return gain * sx, gain * sy


def brush_peak_slip(c_x: Scalarish, mu: Scalarish) -> Float[Array, "..."]:
    """Slip at which the brush model reaches its peak: σ_peak = 3μ/C_x.

    Examples
    --------
    >>> float(brush_peak_slip(30.0, 1.0))
    0.1
    """
    return 3.0 * jnp.asarray(mu) / jnp.asarray(c_x)


def brush_longitudinal_inverse(
    rho: Scalarish, c_x: Scalarish, mu: Scalarish
) -> Float[Array, "..."]:
    """Slip that produces a normalised force ρ in the adhesion region of the brush model.

    In adhesion ρ/μ = sign(u)(1 − (1 − |u|)³), so u = sign(ρ)(1 − (1 − |ρ|/μ)^{1/3}) and
    σ = 3μu/C_x. Forces at or beyond the peak (|ρ| ≥ μ) return the peak slip ±3μ/C_x. Used by the
    simulators and the wear model (the thesis' eq. 4.27 is its small-force limit σ = ρ/C_x).

    Examples
    --------
    >>> s = brush_longitudinal_inverse(0.3, 30.0, 1.0)
    >>> round(float(brush_longitudinal(s, 30.0, 1.0)), 9)
    0.3
    """
    return brush_longitudinal_inverse_and_slope(rho, c_x, mu)[0]


def brush_longitudinal_inverse_and_slope(
    rho: Scalarish, c_x: Scalarish, mu: Scalarish
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """:func:`brush_longitudinal_inverse` and its derivative dσ/dρ, in one pass.

    In adhesion dρ/dσ = C_x (1 − |u|)² = C_x a² with a = (1 − |ρ|/μ)^{1/3}, so dσ/dρ = 1/(C_x a²):
    no second pass of automatic differentiation (a likelihood that needs both per window, as the
    per-tyre model's errors in variables do, halves its cost). At or beyond the peak the slip is
    constant: slope 0.

    Examples
    --------
    >>> s, slope = brush_longitudinal_inverse_and_slope(0.0, 30.0, 1.0)
    >>> float(s), round(float(slope), 6)
    (0.0, 0.033333)
    """
    rho, c_x, mu = jnp.asarray(rho), jnp.asarray(c_x), jnp.asarray(mu)
    remaining = 1.0 - jnp.abs(rho) / mu
    inside = remaining > 1e-12
    # With a = (1 − |ρ|/μ)^{1/3}: 1 − a = (|ρ|/μ)/(1 + a + a²), so σ = 3ρ/(C_x(1 + a + a²)) needs
    # no sign() (whose zero derivative would hide the slope 1/C_x at ρ = 0). cbrt has an infinite
    # derivative at 0, so the masked branch gets a safe argument (double-where).
    a = jnp.cbrt(jnp.where(inside, remaining, 1.0))
    adhesion = 3.0 * rho / (c_x * (1.0 + a + a**2))
    slip = jnp.where(inside, adhesion, jnp.sign(rho) * 3.0 * mu / c_x)
    slope = jnp.where(inside, 1.0 / (c_x * a**2), 0.0)
    return slip, slope


def shaped_longitudinal_inverse_and_slope(
    rho: Scalarish, c_x: Scalarish, mu: Scalarish, shape: Scalarish
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    """Slip of a force on a one-parameter family of curves around the brush model, and dσ/dρ.

    σ = (μ/C_x) g(ρ/μ) with g(y) = 3y/(1 + a + a²), a = (1 − |y|^p)^{1/3}, p = ``shape`` > 0.
    p = 1 is the brush model (:func:`brush_longitudinal_inverse_and_slope`, thesis eq. 3.3–3.4).
    Every member has slope C_x at zero slip and reaches the peak μ at σ = 3μ/C_x with
    dρ/dσ = 0 there, like the brush; they differ in how early the curve bends: g(y) ≈
    y(1 + |y|^p/3) at small forces. The brush bends from the first newton (its force is
    quadratic in |σ| at zero); measured Magic Formula curves are odd in σ, with a cubic first
    correction: p ≈ 2. Fitting the brush to such a tyre reads its straighter start as a higher
    C_x.

    dσ/dρ = (1/C_x)(3/(1 + a + a²) + p|y|^p (1 + 2a)/(a²(1 + a + a²)²)), which is 1/(C_x a²) at
    p = 1. Forces at or beyond the peak map to the peak slip (slope 0), as in the brush inverse.

    Examples
    --------
    >>> s1, d1 = shaped_longitudinal_inverse_and_slope(0.3, 30.0, 1.0, 1.0)
    >>> s0, d0 = brush_longitudinal_inverse_and_slope(0.3, 30.0, 1.0)
    >>> bool(jnp.allclose(s1, s0) and jnp.allclose(d1, d0))
    True
    """
    rho, c_x, mu = jnp.asarray(rho), jnp.asarray(c_x), jnp.asarray(mu)
    shape = jnp.asarray(shape)
    y = rho / mu
    abs_y = jnp.abs(y)
    # |y|^p through exp(p log|y|) with a safe argument: its derivative at y = 0 is finite only
    # for p > 1, and ρ = 0 windows are common (double-where).
    nonzero = abs_y > 0.0
    power = jnp.where(nonzero, jnp.exp(shape * jnp.log(jnp.where(nonzero, abs_y, 1.0))), 0.0)
    remaining = 1.0 - power
    inside = remaining > 1e-12
    a = jnp.cbrt(jnp.where(inside, remaining, 1.0))
    total = 1.0 + a + a**2
    adhesion = 3.0 * rho / (c_x * total)
    slip = jnp.where(inside, adhesion, jnp.sign(rho) * 3.0 * mu / c_x)
    slope = (3.0 / total + shape * power * (1.0 + 2.0 * a) / (a**2 * total**2)) / c_x
    return slip, jnp.where(inside, slope, 0.0)


class BrushTyre(eqx.Module):
    """Brush-model parameters of one tyre (or a batch of tyres, fields broadcasting).

    Parameters
    ----------
    c_x : float or Array
        Longitudinal slip stiffness C_x = ∂ρ_x/∂σ_x at 0 [-] (eq. 3.4 normalised by F_z).
    c_y : float or Array
        Cornering stiffness C_y = ∂ρ_y/∂α at 0 [1/rad] (eq. 5.5 normalised by F_z).
    mu : float or Array
        Friction potential μ_max [-] (eq. 3.3).
    mu_slide_ratio : float or Array
        Sliding-to-peak friction ratio in (0, 1]; 1 is the classical brush model.

    Examples
    --------
    >>> tyre = BrushTyre(c_x=30.0, c_y=20.0, mu=1.0)
    >>> round(float(tyre.longitudinal(0.01)), 4), float(tyre.longitudinal(0.5))
    (0.271, 1.0)
    """

    c_x: Float[ArrayLike, "..."]
    c_y: Float[ArrayLike, "..."]
    mu: Float[ArrayLike, "..."]
    mu_slide_ratio: Float[ArrayLike, "..."] = 1.0

    def __check_init__(self):
        check_positive("BrushTyre", "c_x", self.c_x)
        check_positive("BrushTyre", "c_y", self.c_y)
        check_positive("BrushTyre", "mu", self.mu)
        check_in_range("BrushTyre", "mu_slide_ratio", self.mu_slide_ratio, 1e-6, 1.0)

    def longitudinal(self, slip: Scalarish) -> Float[Array, "..."]:
        """ρ_x(σ_x) of this tyre (see :func:`brush_longitudinal`)."""
        return brush_longitudinal(slip, self.c_x, self.mu, self.mu_slide_ratio)

    def lateral(self, alpha: Scalarish) -> Float[Array, "..."]:
        """ρ_y(α) of this tyre (see :func:`brush_lateral`)."""
        return brush_lateral(alpha, self.c_y, self.mu, self.mu_slide_ratio)
