"""Predictions of a wear fit: worn volume of a set or a new set of a type, relative wear."""

from __future__ import annotations

import jax
import numpy as np

from ..result import Fit
from ..summary import summarize
from .data import c_xr_lognormal
from .fit import wear_fit_parts
from .model import wear_factor


def _draws_gamma_kappa(fit: Fit, set_index: int | None, type_name: str | None, key):
    """Draws of (gamma_ref, kappa, c_xr) for a fitted set, or for a new set of a type."""
    type_names, set_type, extended, _ = wear_fit_parts(fit)
    tau = fit.draws("tau")
    n = tau.shape[0]
    if set_index is not None:
        t = int(set_type[set_index])
        gamma, c_xr = fit.draws("gamma")[:, set_index], fit.draws("c_xr")[:, set_index]
    else:
        if type_name not in type_names:
            raise ValueError(f"type_name: expected one of {type_names}, got {type_name!r}")
        t = type_names.index(type_name)
        z = np.asarray(jax.random.normal(key, (n,)))
        gamma = np.exp(fit.draws("mu_log_gamma")[:, t] + tau * z)
        c_xr = None
    kappa = fit.draws("kappa")[:, t] if extended else np.zeros(n)
    return gamma, kappa, c_xr


def predict_wear_volume(
    fit: Fit,
    kernel: np.ndarray,
    grid_c: np.ndarray,
    set_index: int | None = None,
    type_name: str | None = None,
    c_xr=None,
    seed: int = 0,
) -> np.ndarray:
    """Posterior draws of worn volume per wheel [mm^3], shape (draws, 2 axles).

    ``kernel[a, b]`` is the binned rho^2 F_z V dt of the driving to predict (e.g. 1000 km of a
    profile at an ambient temperature, as ``tyrebayes.simulate.wear.profile_kernel`` makes it).
    Give a fitted ``set_index``, or a ``type_name`` (a new set of that type, gamma from the type
    level) together with its ``c_xr`` (draws or (mean, sd)).
    """
    key = jax.random.PRNGKey(seed)
    gamma, kappa, c_draws = _draws_gamma_kappa(fit, set_index, type_name, key)
    if c_draws is None:
        if c_xr is None:
            raise ValueError("c_xr: expected draws or (mean, sd) for a new tyre set, got None")
        m, sd = c_xr_lognormal(c_xr)
        c_draws = np.exp(
            m + sd * np.asarray(jax.random.normal(jax.random.fold_in(key, 1), gamma.shape))
        )
    factor = np.asarray(wear_factor(grid_c, c_draws, kappa, wear_fit_parts(fit)[3]))  # (n, b)
    return gamma[:, None] * (factor @ np.asarray(kernel).T)


def relative_wear_draws(volume_a: np.ndarray, volume_b: np.ndarray) -> dict:
    """I_rel = I_a / I_b (eq. 4.28) and |I_a - I_b| / max (thesis Sec. 6.2), summarised."""
    a, b = np.asarray(volume_a), np.asarray(volume_b)
    ratio = a / b
    diff = np.abs(a - b) / np.maximum(a, b)
    return {
        "i_rel": summarize(ratio).to_dict(),
        "i_rel_thesis": summarize(diff).to_dict(),
        "draws": ratio,
    }


def gamma_summary(fit: Fit) -> list[dict]:
    """Posterior of gamma_ref per tyre set in the ``{"mean","sd","hdi_90"}`` form [mm^3/J]."""
    gamma = fit.draws("gamma")
    return [summarize(gamma[:, i]).to_dict() for i in range(gamma.shape[1])]
