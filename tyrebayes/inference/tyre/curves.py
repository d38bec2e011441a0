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

CURVE_MODELS = ("magic", "shaped", "brush", "linear")


# The Magic Formula curve with its shape and curvature drawn from the measured tyres'
# (tyre_curve_prior.py): no single shape, and none that bends as early as the brush
# (benchmarks/results/external_drives.json compares the models on drives the package did not make).
DEFAULT_MODEL = "magic"


def check_model(model: str) -> None:
    """Raise ValueError unless ``model`` is one of :data:`CURVE_MODELS`."""
    if model not in CURVE_MODELS:
        raise ValueError(f"tyre-curve model: expected one of {CURVE_MODELS}, got {model!r}")


def _slip_and_slope(model: str, rho, c_x, mu, params: dict):
    """Slip of a force in adhesion, f⁻¹(ρ), and its derivative dσ/dρ, elementwise.

    Forces at or beyond the peak map to the peak slip (zero derivative): a μ below the measured
    forces then cannot fit their slips, which is how the slip windows bound μ from below.
    ``params`` holds the curve's shape sites of ``model`` (``curve_shape_c``, ``curve_curvature_e``
    for ``"magic"``, ``curve_shape`` for ``"shaped"``).
    """
    if model == "linear":
        return rho / c_x, jnp.broadcast_to(1.0 / c_x, jnp.shape(rho))
    if model == "magic":
        return magic_formula_inverse_and_slope(
            rho, c_x, mu, params["curve_shape_c"], params["curve_curvature_e"]
        )
    if model == "shaped":
        return shaped_longitudinal_inverse_and_slope(rho, c_x, mu, params["curve_shape"])
    return brush_longitudinal_inverse_and_slope(rho, c_x, mu)


def curve_slip(model: str, rho, c_x, mu, params: dict):
    """Slip of the fitted curve at force ρ in adhesion [-] (``params`` as :func:`_slip_and_slope`).

    Broadcasts over posterior draws: ``c_x``, ``mu`` and the shape entries of ``params`` may be
    arrays of draws.
    """
    return _slip_and_slope(model, jnp.asarray(rho), jnp.asarray(c_x), jnp.asarray(mu), params)[0]
