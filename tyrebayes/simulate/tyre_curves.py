"""Forward and inverse longitudinal tyre curves used as the simulator's truth (NumPy, vectorised).

Two truths, both parameterised by the stiffness C_x (slope at zero slip, at the tyre's static load)
and the peak μ, so that the inference targets mean the same thing under either:

* ``"brush"`` — :func:`tyrebayes.physics.tyre.brush_longitudinal` (flat or falling after the peak
  by ``mu_slide_ratio``); inverse in closed form
  (:func:`tyrebayes.physics.tyre.brush_longitudinal_inverse`); both through NumPy twins.
* ``"magic_formula"`` — a measured Magic Formula shape (PCX1, PEX1–3 and the load dependences
  PKX2–3, PDX2 of ``TyreSpec.magic_formula``: Pacejka's 205/60R15 by default, or a set drawn from
  the shipped database with :func:`~tyrebayes.simulate.tyre_spec.draw_database_curve`) scaled
  so that its slope at the nominal load ``fz0_n`` is C_x and its peak there is μ. Real tyres
  fall after the peak, which the brush model cannot; inverse by safeguarded Newton.

Examples
--------
>>> import numpy as np
>>> from tyrebayes.simulate.tyre_spec import TyreSpec
>>> spec = TyreSpec.from_type("summer")
>>> rho = tyre_force("magic_formula", np.array([0.01]), 4000.0, 40.0, 1.0, spec, 4000.0)
>>> s, ok = tyre_slip("magic_formula", rho, 4000.0, 40.0, 1.0, spec, 4000.0)
>>> bool(abs(s[0] - 0.01) < 1e-9 and ok.all())
True
"""

from __future__ import annotations

import numpy as np

from .tyre_spec import TYRE_MODELS, TyreSpec

#: Largest share of the peak a quasi-static (non-ABS) manoeuvre may ask of a tyre; beyond it the
#: simulator clips the force demand and counts the clipped samples.
MAX_UTILISATION = 0.97


def brush_force_np(slip, c_x, mu, mu_slide_ratio=1.0, slide_width: float = 2.0) -> np.ndarray:
    """NumPy twin of :func:`tyrebayes.physics.tyre.brush_longitudinal` (same formula).

    Eager JAX compiles every primitive for each new array shape; the simulator runs on arrays of
    arbitrary length, so its hot path is NumPy. Tests check the twins agree with the physics module.
    """
    mu = np.asarray(mu, dtype=float)
    u = np.asarray(c_x) * np.asarray(slip, dtype=float) / (3.0 * mu)
    abs_u = np.abs(u)
    adhesion = mu * (3.0 * u - 3.0 * u * abs_u + u**3)
    fall = (1.0 - np.asarray(mu_slide_ratio)) * (
        1.0 - np.exp(-(((abs_u - 1.0) / slide_width) ** 2))
    )
    return np.where(abs_u < 1.0, adhesion, np.sign(u) * mu * (1.0 - fall))


def brush_inverse_np(rho, c_x, mu) -> np.ndarray:
    """NumPy twin of :func:`tyrebayes.physics.tyre.brush_longitudinal_inverse`."""
    rho = np.asarray(rho, dtype=float)
    c_x, mu = np.asarray(c_x, dtype=float), np.asarray(mu, dtype=float)
    remaining = 1.0 - np.abs(rho) / mu
    inside = remaining > 1e-12
    a = np.cbrt(np.where(inside, remaining, 1.0))
    return np.where(inside, 3.0 * rho / (c_x * (1.0 + a + a**2)), np.sign(rho) * 3.0 * mu / c_x)


def _check_model(model: str) -> None:
    if model not in TYRE_MODELS:
        raise ValueError(f"tyre_model: expected one of {TYRE_MODELS}, got {model!r}")


def _mf_terms(fz, c_x, mu, spec: TyreSpec, fz0):
    """B, C, D(=μ_eff), E of the scaled Magic Formula at load fz."""
    mf = spec.magic_formula
    dfz = (np.asarray(fz, dtype=float) - fz0) / fz0
    mu_eff = mu * (1.0 + mf.pdx2 / mf.pdx1 * dfz)
    k = c_x * (1.0 + mf.pkx2 / mf.pkx1 * dfz) * np.exp(mf.pkx3 * dfz)
    e = np.minimum(mf.pex1 + mf.pex2 * dfz + mf.pex3 * dfz**2, 1.0)
    c = mf.pcx1
    b = k / (c * mu_eff)
    return b, c, mu_eff, e


def _mf_rho_and_slope(slip, b, c, d, e):
    bs = b * slip
    inner = bs - e * (bs - np.arctan(bs))
    rho = d * np.sin(c * np.arctan(inner))
    d_inner = b * (1.0 - e + e / (1.0 + bs**2))
    slope = d * np.cos(c * np.arctan(inner)) * c / (1.0 + inner**2) * d_inner
    return rho, slope


def _solve_x(inner, e, x_max):
    """x ≥ 0 with x(1 − E) + E·atan(x) = inner (monotone for E ≤ 1), Newton kept in [0, x_max]."""
    x = np.clip(np.asarray(inner, dtype=float), 0.0, x_max)
    x, e, inner, x_max = np.broadcast_arrays(x, e, inner, x_max)
    shape = x.shape
    # Flat copies: the Newton loop indexes the unconverged entries with flat indices.
    x, e, inner, x_max = (np.array(z, dtype=float).ravel() for z in (x, e, inner, x_max))
    todo = np.flatnonzero(inner > 0)
    for _ in range(40):
        if todo.size == 0:
            break
        xt, et = x[todo], e[todo]
        g = xt * (1.0 - et) + et * np.arctan(xt) - inner[todo]
        dg = (1.0 - et) + et / (1.0 + xt**2)
        x[todo] = np.clip(xt - g / np.maximum(dg, 1e-12), 0.0, x_max[todo])
        todo = todo[np.abs(g) > 1e-13 * np.maximum(1.0, inner[todo])]
    return x.reshape(shape)


def _x_peak(e: np.ndarray, c: float) -> np.ndarray:
    """x = Bσ at the Magic Formula peak for curvature(s) E: solved on a grid of E, interpolated.

    The peak depends on E only (C is a constant), and E varies smoothly with the load, so 257
    Newton solves replace one per sample.
    """
    target = np.tan(np.pi / (2.0 * c)) if c > 1.0 else 1e6
    e = np.asarray(e, dtype=float)
    lo, hi = float(np.min(e)), float(np.max(e))
    if hi - lo < 1e-12:
        return np.full(e.shape, float(_solve_x(np.array([target]), np.array([lo]), np.inf)[0]))
    grid = np.linspace(lo, hi, 257)
    x_grid = _solve_x(np.full(grid.shape, target), grid, np.inf)
    return np.interp(e, grid, x_grid)


def peak_slip(model: str, fz, c_x, mu, spec: TyreSpec, fz0: float | np.ndarray) -> np.ndarray:
    """Positive slip at which |ρ| peaks [-] (brush: 3μ/C_x; MF: where C·atan(·) = π/2)."""
    _check_model(model)
    if model == "brush":
        return np.broadcast_to(
            3.0 * np.asarray(mu) / np.asarray(c_x), np.shape(fz * c_x * mu)
        ).copy()
    b, c, _, e = _mf_terms(fz, c_x, mu, spec, fz0)
    return _x_peak(np.broadcast_to(e, np.shape(b)), c) / b


def tyre_force(
    model: str, slip, fz, c_x, mu, spec: TyreSpec, fz0: float | np.ndarray
) -> np.ndarray:
    """Normalised longitudinal force ρ_x(σ_x) of the truth tyre [-].

    Parameters
    ----------
    model : str
        ``"brush"`` or ``"magic_formula"``.
    slip : array
        Longitudinal slip σ_x [-].
    fz : array
        Wheel load F_z [N] (only the Magic Formula depends on it).
    c_x, mu : array
        Stiffness at zero slip (at load ``fz0``) [-] and peak friction [-].
    spec : TyreSpec
        Brush sliding ratio and Magic Formula shape.
    fz0 : float
        Nominal (static) load of this wheel [N].
    """
    _check_model(model)
    slip = np.asarray(slip, dtype=float)
    if model == "brush":
        return brush_force_np(slip, c_x, mu, spec.mu_slide_ratio)
    b, c, d, e = _mf_terms(fz, c_x, mu, spec, fz0)
    return _mf_rho_and_slope(slip, b, c, d, e)[0]


def tyre_slip(
    model: str, rho, fz, c_x, mu, spec: TyreSpec, fz0: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Slip that yields the force ρ_x on the rising branch (inverse of :func:`tyre_force`).

    Demands beyond :data:`MAX_UTILISATION` of the peak are clipped to it.

    Returns
    -------
    (slip, ok)
        Slip [-] and a boolean array, False where the demand was clipped (a failure as data: the
        driver asked for more than the road gives).
    """
    _check_model(model)
    rho = np.asarray(rho, dtype=float)
    if model == "brush":
        mu_eff = np.broadcast_to(np.asarray(mu, dtype=float), np.shape(rho))
    else:
        _, _, mu_eff, _ = _mf_terms(fz, c_x, mu, spec, fz0)
        mu_eff = np.broadcast_to(mu_eff, np.shape(rho))
    limit = MAX_UTILISATION * mu_eff
    ok = np.abs(rho) <= limit
    rho_c = np.clip(rho, -limit, limit)
    if model == "brush":
        # The brush inverse is exact in the adhesion region; a falling branch (mu_slide_ratio < 1)
        # only begins beyond the peak, which the clip keeps us away from.
        return brush_inverse_np(rho_c, c_x, mu), ok
    b, c, d, e = _mf_terms(fz, c_x, mu, spec, fz0)
    # On the rising branch sin(C·atan(inner)) = |ρ|/D inverts in closed form; the remaining
    # x(1 − E) + E atan x = inner (x = Bσ) is monotone and solved by Newton.
    x_pk = _x_peak(np.broadcast_to(e, np.shape(b)), c)
    inner = np.tan(np.arcsin(np.clip(np.abs(rho_c) / d, 0.0, 1.0)) / c)
    s = _solve_x(inner, e, x_pk) / b
    residual = np.abs(_mf_rho_and_slope(s, b, c, d, e)[0] - np.abs(rho_c))
    ok = ok & (residual < 1e-8)
    return np.sign(rho_c) * s, ok
