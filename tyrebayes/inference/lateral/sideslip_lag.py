"""The rear axle's sideslip lag: the kinematic equation's residuals as output error.

:func:`sideslip_lag` turns the lateral model's kinematic equation errors into residuals of a_y
against what the yaw motion predicts through the rear axle's sideslip lag, with the fourth-order
compact derivative (:func:`compact_p`, :func:`compact_q`) and a tridiagonal solve
(:func:`thomas_solve` for many short systems: the in-car estimator's blocks).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jax.lax.linalg import tridiagonal_solve
from jaxtyping import Array, Bool, Float


def compact_p(x: jnp.ndarray, axis: int = 0) -> jnp.ndarray:
    """P x of the compact derivative D = P⁻¹Q (:func:`sideslip_lag`) along ``axis``; wraps at
    the ends, which no equation reads."""
    return 0.25 * jnp.roll(x, 1, axis) + x + 0.25 * jnp.roll(x, -1, axis)


def compact_q(x: jnp.ndarray, dt: float | jnp.ndarray, axis: int = 0) -> jnp.ndarray:
    """Q x of the compact derivative (:func:`compact_p`)."""
    return 0.75 * (jnp.roll(x, -1, axis) - jnp.roll(x, 1, axis)) / dt


def sideslip_lag(
    equation: Float[Array, "*batch n k"],
    settling: Float[Array, "*batch n"],
    valid: Bool[Array, "*batch n"],
    dt: float | jnp.ndarray,
    solve=tridiagonal_solve,
) -> Float[Array, "*batch n k"]:
    """Λ (Q + PΛ)⁻¹ of P-premultiplied equation errors: the kinematic equation's residuals.

    The kinematic equation's sideslip rate D(V_x α_r) differentiates the slip angle that the
    measured a_y gives, and so a_y's noise: its equation error at the true parameters is
    (I + DΛ⁻¹) ε, with Λ = diag(``settling``) the rate at which the rear axle's sideslip
    settles. Fitted as it stands, that error shrinks as the rear axle stiffens (Λ grows); in
    steady cornering, where the term carries no signal, the fit read the tyres stiff by a
    margin that grew with the square of a_y's noise
    (``benchmarks/results/lateral_simulated_drives.json``). Λ (D + Λ)⁻¹ applied to the equation
    error leaves ε: the residual is then a_y against what the yaw motion predicts through the
    rear axle's sideslip lag (output error, not equation error), with the slip angle linearised
    at the measured a_y. D is the fourth-order compact (Padé) derivative, P = (¼, 1, ¼),
    Q = ¾(−1, 0, 1)/Δt, so D + Λ = P⁻¹(Q + PΛ) and the inverse is one tridiagonal solve. A
    sample outside ``valid`` is a row w = 0: stretches between gaps are solved apart, each
    starting at rest relative to the measured slip. Time runs along the second-last axis of
    ``equation``; its columns (k) are solved together. ``solve``: the tridiagonal solver
    (:func:`thomas_solve` for many short systems).
    """
    q = 0.75 / dt
    zero = jnp.zeros_like(settling[..., :1])
    lower = jnp.concatenate([zero, -q + 0.25 * settling[..., :-1]], axis=-1)
    upper = jnp.concatenate([q + 0.25 * settling[..., 1:], zero], axis=-1)
    lower, upper = (jnp.where(valid, x, 0.0) for x in (lower, upper))
    diagonal = jnp.where(valid, settling, 1.0)
    rhs = jnp.where(valid[..., None], equation, 0.0)
    return settling[..., None] * solve(lower, diagonal, upper, rhs)


def thomas_solve(lower, diagonal, upper, rhs):
    """:func:`jax.lax.linalg.tridiagonal_solve` by the Thomas algorithm, scanned along time.

    For many short systems at once (the in-car estimator's blocks and rear nodes): the library's
    solve takes each system in turn, this one sweeps all of them together, sample by sample.
    Without pivoting: (Q + PΛ) has Λ on its diagonal and ∓¾/Δt + Λ/4 beside it; where Λ < 3/Δt
    the off-diagonal products are negative and every pivot is at least Λ, and where Λ is larger
    P's diagonal dominance carries over (``tests/inference/online/test_lateral_statistics.py``
    compares the two solvers' residuals).
    """
    lo, d, up = (jnp.moveaxis(x, -1, 0) for x in (lower, diagonal, upper))
    b = jnp.moveaxis(rhs, -2, 0)

    def forward(carry, row):
        c_prev, d_prev = carry
        below, dd, u, bb = row
        inverse = 1.0 / (dd - below * c_prev)  # one division per system, not per column
        c = u * inverse
        x = (bb - below[..., None] * d_prev) * inverse[..., None]
        return (c, x), (c, x)

    start = (jnp.zeros_like(d[0]), jnp.zeros_like(b[0]))
    _, (c, x) = jax.lax.scan(forward, start, (lo, d, up, b))

    def backward(after, row):
        c_i, x_i = row
        value = x_i - c_i[..., None] * after
        return value, value

    _, solution = jax.lax.scan(backward, jnp.zeros_like(b[0]), (c, x), reverse=True)
    return jnp.moveaxis(solution, 0, -2)
