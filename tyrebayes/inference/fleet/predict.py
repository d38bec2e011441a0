"""Predictions of a fleet fit: friction of a new set, held-out densities, the fit's summary."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd

from ..._domain import SURFACES, TYRE_TYPES
from ..._errors import BadInputError
from ..result import Fit
from ..summary import summarize
from .data import fleet_data_from_table
from .model import X_SCALE, normal_logpdf
from .priors import load_tyre_type_priors


def _check_prediction_inputs(fit: Fit, c_xr, c_xr_sd, tyre_type, surface):
    if fit.kind != "fleet":
        raise BadInputError(f"fit: expected a fleet fit, got a {fit.kind} fit")
    if surface not in SURFACES:
        raise BadInputError(f"surface: expected one of {list(SURFACES)}, got {surface!r}")
    if tyre_type is not None and tyre_type not in TYRE_TYPES:
        raise BadInputError(
            f"tyre type: expected one of {list(TYRE_TYPES)} or none, got {tyre_type!r}"
        )
    if not (np.isfinite(c_xr) and c_xr > 0):
        raise BadInputError(f"c_xr: expected a positive stiffness, got {c_xr}")
    if not (np.isfinite(c_xr_sd) and c_xr_sd >= 0):
        raise BadInputError(f"c_xr_sd: expected >= 0, got {c_xr_sd}")
    for name in ("a", "b", "sigma", "stiff_loc", "stiff_scale"):
        if name not in fit.posterior.data_vars:
            raise BadInputError(f"fleet fit: expected posterior variable {name!r}, not found")


def type_probabilities(fit: Fit, c_xr: float, c_xr_sd: float) -> np.ndarray:
    """Per posterior draw, P(type | C_xr) with equal prior type shares. Shape (draws, 3).

    A set's measured stiffness is compared with each type's log-normal stiffness population
    (its spread widened by the measurement error). The fleet's own type mix is a sampling
    design, not a population, so it is not used as the prior.
    """
    loc = fit.draws("stiff_loc")
    scale = np.sqrt(fit.draws("stiff_scale") ** 2 + (c_xr_sd / c_xr) ** 2)
    logp = normal_logpdf(math.log(c_xr), loc, scale)
    logp -= logp.max(axis=1, keepdims=True)
    w = np.exp(logp)
    return w / w.sum(axis=1, keepdims=True)


def predict_friction(
    fit: Fit,
    c_xr: float,
    c_xr_sd: float = 0.0,
    tyre_type: str | None = None,
    surface: str = "snow",
    *,
    seed: int = 0,
) -> np.ndarray:
    """Posterior predictive draws of mu_max for a new tyre set.

    Parameters
    ----------
    fit : Fit
        A fleet fit from :func:`fit_fleet` (or :func:`~tyrebayes.inference.result.load_fit`).
    c_xr, c_xr_sd : float
        The new set's stiffness posterior, summarised as mean and sd (dimensionless C_xr);
        treated as Normal truncated at 1. ``c_xr_sd = 0`` means an exact value.
    tyre_type : str or None
        ``winter``, ``all_season``, ``summer``; ``None`` mixes over types with
        :func:`type_probabilities`.
    surface : str
        ``snow``, ``ice``, ``wet`` or ``dry``.
    seed : int
        Randomness of the predictive noise.

    Returns
    -------
    numpy.ndarray
        One predictive draw of mu per posterior draw (residual scatter included).

    Examples
    --------
    >>> draws = predict_friction(fit, 30.0, 1.0, "winter")  # doctest: +SKIP
    """
    _check_prediction_inputs(fit, c_xr, c_xr_sd, tyre_type, surface)
    rng = np.random.default_rng(seed)
    a, b, sigma = (fit.draws(n) for n in ("a", "b", "sigma"))
    n = a.shape[0]
    s = SURFACES.index(surface)
    if tyre_type is None:
        w = type_probabilities(fit, c_xr, c_xr_sd)
        t = (rng.random(n)[:, None] > np.cumsum(w, axis=1)).sum(axis=1)
        t = np.minimum(t, len(TYRE_TYPES) - 1)
    else:
        t = np.full(n, TYRE_TYPES.index(tyre_type))
    c_ref = np.asarray(fit.attr("c_xr_ref"))
    c = np.maximum(c_xr + c_xr_sd * rng.standard_normal(n), 1.0)
    idx = np.arange(n)
    z = X_SCALE / c - X_SCALE / c_ref[t]
    mean = a[idx, s, t] + b[idx, s, t] * z
    return mean + sigma[idx, s, t] * rng.standard_normal(n)


def _heldout_mean_sigma(fit: Fit, table, outcome, seed, require_outcome):
    priors = load_tyre_type_priors()
    data = fleet_data_from_table(
        table, outcome, default_c_xr_sd=priors.default_c_xr_sd, require_outcome=require_outcome
    )
    a, b, sigma = (fit.draws(n) for n in ("a", "b", "sigma"))
    c_ref = np.asarray(fit.attr("c_xr_ref"))
    rng = np.random.default_rng(seed)
    n = a.shape[0]
    c_tyre = np.maximum(
        data.c_xr[None] + data.c_xr_sd[None] * rng.standard_normal((n, data.n_tyres)), 1.0
    )
    rt, rs = data.row_type, data.row_surface
    z = X_SCALE / c_tyre[:, data.row_tyre] - X_SCALE / c_ref[rt]
    return data, a[:, rs, rt] + b[:, rs, rt] * z, sigma[:, rs, rt], rng


def predictive_logpdf(
    fit: Fit, table: pd.DataFrame, outcome: str = "mu", *, seed: int = 0
) -> np.ndarray:
    """Log posterior predictive density of each row of a held-out fleet table.

    Each held-out set's stiffness is its measurement (``c_xr`` +- ``c_xr_sd``), as in
    :func:`predict_friction`; its type is the row's ``tyre_type``. Returns one log density per row
    (log of the mean over posterior draws), in the table's row order.
    """
    data, mean, sd, _ = _heldout_mean_sigma(fit, table, outcome, seed, True)
    lp = normal_logpdf(data.y[None], mean, sd)
    m = lp.max(axis=0)
    return m + np.log(np.mean(np.exp(lp - m), axis=0))


def predictive_draws(
    fit: Fit, table: pd.DataFrame, outcome: str = "mu", *, seed: int = 0
) -> np.ndarray:
    """Posterior predictive draws of the outcome for each row of a (new) fleet table.

    The outcome column may be absent. Returns an array (draws, rows) in the table's row order,
    residual scatter included; stiffness handled as in :func:`predictive_logpdf`.
    """
    _, mean, sd, rng = _heldout_mean_sigma(fit, table, outcome, seed, outcome in table.columns)
    return mean + sd * rng.standard_normal(mean.shape)


def has_lateral_ratio(fit: Fit) -> bool:
    """Whether a fleet fit carries the per-type ratio c_y / C_xr (some set had a lateral estimate).

    Examples
    --------
    >>> has_lateral_ratio(fit)  # doctest: +SKIP
    True
    """
    return fit.kind == "fleet" and "k_loc" in fit.posterior.data_vars


def lateral_sets_per_type(fit: Fit) -> dict[str, int]:
    """How many sets of each type had a lateral estimate in the fleet table (0 for each type of a
    fit made before the ratio existed)."""
    raw = fit.data.attrs.get("lateral_sets_per_type")
    return {t: 0 for t in TYRE_TYPES} if raw is None else dict(json.loads(raw))


def lateral_ratio_draws(
    fit: Fit, tyre_type: str, n: int | None = None, *, seed: int = 0
) -> np.ndarray:
    """Posterior predictive draws of k = c_y / C_xr for a new set of a type [1/rad per unit C_xr].

    Each draw is one posterior draw of the type's population (``k_loc``, ``k_scale``) and one set
    from it, so the spread holds both the uncertainty of the type's median and the set-to-set
    scatter. A type without lateral estimates in the fleet gives its prior predictive
    (:func:`lateral_sets_per_type` says which).

    Parameters
    ----------
    fit : Fit
        A fleet fit with the ratio (:func:`has_lateral_ratio`).
    tyre_type : str
        ``winter``, ``all_season`` or ``summer``.
    n : int, optional
        Number of draws (default: one per posterior draw; more or fewer resample them).
    seed : int
        Randomness of the set-to-set scatter and the resampling.

    Returns
    -------
    numpy.ndarray
        ``n`` draws of k; c_y = k · C_xr [1/rad over the static axle load].

    Raises
    ------
    BadInputError
        Not a fleet fit, no lateral ratio in it, or an unknown type.

    Examples
    --------
    >>> k = lateral_ratio_draws(fit, "winter", 1000)  # doctest: +SKIP
    >>> float(np.median(k))  # doctest: +SKIP
    0.45
    """
    if fit.kind != "fleet":
        raise BadInputError(f"fit: expected a fleet fit, got a {fit.kind} fit")
    if tyre_type not in TYRE_TYPES:
        raise BadInputError(f"tyre type: expected one of {list(TYRE_TYPES)}, got {tyre_type!r}")
    if not has_lateral_ratio(fit):
        raise BadInputError(
            "fleet fit: expected the lateral ratio c_y / C_xr (a table with c_y), got a fit "
            "without any lateral estimate"
        )
    t = TYRE_TYPES.index(tyre_type)
    loc, scale = fit.draws("k_loc")[:, t], fit.draws("k_scale")[:, t]
    rng = np.random.default_rng(seed)
    if n is not None:
        if n < 1:
            raise BadInputError(f"n: expected at least 1 draw, got {n}")
        idx = rng.integers(0, loc.size, n) if n > loc.size else rng.permutation(loc.size)[:n]
        loc, scale = loc[idx], scale[idx]
    return np.exp(loc + scale * rng.standard_normal(loc.size))


def lateral_ratio_summary(fit: Fit) -> dict | None:
    """Per type: the ratio's median (``exp(k_loc)``) and spread (``k_scale``) as ``{"mean",
    "sd", "hdi_90"}``, the sets it was learnt from, and ``"from"`` (``"data"`` or ``"prior"``);
    None for a fit without the ratio. The ``lateral_ratio`` object of ``fit-fleet --json``.

    Examples
    --------
    >>> lateral_ratio_summary(fit)["winter"]["from"]  # doctest: +SKIP
    'data'
    """
    if not has_lateral_ratio(fit):
        return None
    counts = lateral_sets_per_type(fit)
    out = {}
    for i, t in enumerate(TYRE_TYPES):
        out[t] = {
            "median_ratio": summarize(np.exp(fit.draws("k_loc")[:, i])).to_dict(),
            "log_spread": summarize(fit.draws("k_scale")[:, i]).to_dict(),
            "n_sets": int(counts.get(t, 0)),
            "from": "data" if counts.get(t, 0) > 0 else "prior",
        }
    return out


def fit_summary(fit: Fit) -> dict:
    """JSON-ready summary of a fleet fit: diagnostics and a, b, sigma per fitted surface and type.

    The ``fit-fleet --json`` object (less ``out``) and the report's fleet parameters.
    """
    post = fit.posterior
    fitted = fit.attr("fitted_surfaces")
    present = sorted(set(np.asarray(fit.data["constant_data"]["row_type"]).tolist()))
    types = [str(post["tyre_type"].values[i]) for i in present]
    params = {
        s: {
            t: {
                v: summarize(post[v].sel(surface=s, tyre_type=t).values).to_dict()
                for v in ("a", "b", "sigma")
            }
            for t in types
        }
        for s in fitted
    }
    return {
        "converged": fit.converged,
        "adequate": fit.adequate,
        "adequacy_reasons": list(fit.diagnostics.adequacy_reasons),
        "diagnostics": fit.diagnostics.as_dict(),
        "outcome": str(fit.data.attrs["outcome"]),
        "n_sets": int(post.sizes["tyre"]),
        "n_rows": int(fit.data["observed_data"].sizes["row"]),
        "fitted_surfaces": fitted,
        "parameters": params,
        "lateral_ratio": lateral_ratio_summary(fit),
    }
