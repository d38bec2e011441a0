"""The tyre curves the per-tyre model can use, inverted: the slip of a force in adhesion.

Re-exported by :mod:`tyrebayes.inference.tyre.model`.
"""

from __future__ import annotations

import jax.numpy as jnp

from ...physics.tyre import (
    brush_longitudinal_inverse_and_slope,
    magic_formula_inverse_and_slope,
    shaped_longitudinal_inverse_and_slope,
)

MODEL_KINDS = ("magic", "shaped", "brush", "linear")


# The Magic Formula curve with its shape and curvature drawn from the measured tyres'
# (tyre_curve_prior.py): no single shape, and none that bends as early as the brush
# (benchmarks/results/external_drives.json compares the kinds on drives the package did not make).
DEFAULT_KIND = "magic"


def check_kind(kind: str) -> None:
    """Raise ValueError unless ``kind`` is one of :data:`MODEL_KINDS`."""
    if kind not in MODEL_KINDS:
        raise ValueError(f"tyre model kind: expected one of {MODEL_KINDS}, got {kind!r}")


def _slip_and_slope(kind: str, rho, c_x, mu, params: dict):
    """Slip of a force in adhesion, f⁻¹(ρ), and its derivative dσ/dρ, elementwise.

    Forces at or beyond the peak map to the peak slip (zero derivative): a μ below the measured
    forces then cannot fit their slips, which is how the slip windows bound μ from below.
    ``params`` holds the curve's shape sites of ``kind`` (``curve_shape_c``, ``curve_curvature_e``
    for ``"magic"``, ``curve_shape`` for ``"shaped"``).
    """
    if kind == "linear":
        return rho / c_x, jnp.broadcast_to(1.0 / c_x, jnp.shape(rho))
    if kind == "magic":
        return magic_formula_inverse_and_slope(
            rho, c_x, mu, params["curve_shape_c"], params["curve_curvature_e"]
        )
    if kind == "shaped":
        return shaped_longitudinal_inverse_and_slope(rho, c_x, mu, params["curve_shape"])
    return brush_longitudinal_inverse_and_slope(rho, c_x, mu)


def curve_slip(kind: str, rho, c_x, mu, params: dict):
    """Slip of the fitted curve at force ρ in adhesion [-] (``params`` as :func:`_slip_and_slope`).

    Broadcasts over posterior draws: ``c_x``, ``mu`` and the shape entries of ``params`` may be
    arrays of draws.
    """
    return _slip_and_slope(kind, jnp.asarray(rho), jnp.asarray(c_x), jnp.asarray(mu), params)[0]
