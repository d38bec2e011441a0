"""Predictions of a drive-history wear fit: tread depth against distance, km to 3 and 1.6 mm.

Per posterior draw: the current set's wear rate per axle is γ exp(κ (T − 20)) times the history's
friction work per km of that axle, longitudinal plus lateral (eq. 4.19a + b, the lateral work at
its posterior scale: the cornering stiffness' error), all drives, each weighted by the distance
it stands for; the
current depth is the pair's initial depth (posterior with readings, the new-tyre prior without)
minus what the history wore off it. Future driving is assumed like the history's and no further
rotation is assumed. The high-wear warning compares the car set's worn mass per 1000 km with the
ADAC convoy figure of the tyre type (``tyrebayes/data/wear_by_tyre_type.csv``, mid-range); the
command turns the ratio's draws into a warning with :func:`tyrebayes.decisions.high_wear_warning`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..._resources import data_dir
from ...physics.wear import TreadGeometry
from ..result import Fit
from ..summary import summarize
from .history import DriveHistory, TreadReadings
from .history_fit import NEW_DEPTH_MM, NEW_DEPTH_SD_MM

#: Tread limits of the predictions [mm]: a common replacement advice and the legal minimum (EU).
LIMITS_MM = (3.0, 1.6)


def reference_wear_g_per_1000km(tyre_type: str) -> float:
    """Mid-range ADAC convoy wear of a tyre type, per car set per 1000 km [g]."""
    table = pd.read_csv(data_dir() / "wear_by_tyre_type.csv")
    rows = table[table["tyre_type"] == tyre_type]
    if rows.empty:
        raise ValueError(
            f"tyre_type: expected one of {sorted(set(table['tyre_type']))}, got {tyre_type!r}"
        )
    lo = rows["wear_min_g_per_1000km"].dropna()
    hi = rows["wear_max_g_per_1000km"].dropna()
    return float((lo.mean() + hi.mean()) / 2.0)


def wear_history_predictions(
    fit: Fit,
    history: DriveHistory,
    readings: TreadReadings | None = None,
    *,
    tyre_type: str = "summer",
    geom: TreadGeometry | None = None,
    horizon_km: float = 60000.0,
    seed: int = 0,
) -> tuple[dict, np.ndarray]:
    """Predictive tread depth, distance to the limits and the high-wear warning (draws summarised).

    Returns a JSON-ready dict: ``gamma``, ``gamma_work`` (γ times the work-scale error: per
    joule of the evidence's work), ``kappa`` (extended), ``wear_mm_per_1000km``
    (front, rear), ``depth_now_mm`` (front, rear), ``km_to_3mm`` and ``km_to_1_6mm`` (from the
    last drive; the first axle to reach the limit), ``depth_curve`` (quantiles 5/50/95 % of the
    lower axle at distances ahead), ``tyre_changes`` and ``wear_over_reference`` (the car set's
    worn mass over the type's reference). The second item returned is the draws of that ratio,
    for :func:`tyrebayes.decisions.high_wear_warning`.
    """
    geom = TreadGeometry() if geom is None else geom
    gamma = fit.draws("gamma_work")  # per joule of evidence work: what the history fixed
    kappa = fit.draws("kappa") if "kappa" in fit.posterior.data_vars else np.zeros_like(gamma)
    factor = (
        gamma[:, None]
        * np.exp(kappa[:, None] * (history.tyre_temperature_c[None, :] - 20.0))
        / 2.0
        / geom.wear_area_mm2
    )  # (draws, n) mm per tyre per J of axle work
    if "log_lateral_ratio" in fit.posterior.data_vars:
        ratio = np.exp(fit.draws("log_lateral_ratio"))  # (draws, 2): q_a / s
    else:
        ratio = np.ones((gamma.size, 2))
    work = history.work_j[None, :, :] + ratio[:, None, :] * history.work_y_j[None, :, :]
    loss = factor[:, :, None] * work  # (draws, n, 2)
    per_km = loss.sum(axis=1) / history.total_km  # mm per km per axle position
    rng = np.random.default_rng(seed)
    n_draws = gamma.size
    if "initial_depth_mm" in fit.posterior.data_vars:
        d0 = fit.draws("initial_depth_mm")
    else:
        d0 = NEW_DEPTH_MM + NEW_DEPTH_SD_MM * rng.standard_normal((n_draws, history.n_pairs))
    current = history.pair[-1]
    worn = np.zeros((n_draws, 2))
    for a, p in enumerate(current):
        on = history.pair == p  # (n, 2): intervals where pair p sat on each axle
        worn[:, a] = (loss * on[None, :, :]).sum(axis=(1, 2))
    depth_now = d0[:, current] - worn
    out: dict = {
        "gamma": summarize(fit.draws("gamma")).to_dict(),
        "gamma_work": summarize(gamma).to_dict(),
    }
    out["lateral_work"] = {
        "cornering_stiffness_source": history.lateral_source,
        "cornering_stiffness_log_sd": float(history.lateral_log_sd),
        "share_of_work": {
            name: float(
                history.work_y_j[:, a].sum()
                / max(history.work_j[:, a].sum() + history.work_y_j[:, a].sum(), 1e-300)
            )
            for a, name in enumerate(("front", "rear"))
        },
    }
    if "lateral_work_scale" in fit.posterior.data_vars:
        q = fit.draws("lateral_work_scale")
        out["lateral_work"]["scale"] = {
            name: summarize(q[:, a]).to_dict() for a, name in enumerate(("front", "rear"))
        }
    if "kappa" in fit.posterior.data_vars:
        out["kappa"] = summarize(kappa).to_dict()
    out["wear_mm_per_1000km"] = {
        name: summarize(1000.0 * per_km[:, a]).to_dict() for a, name in enumerate(("front", "rear"))
    }
    out["depth_now_mm"] = {
        name: summarize(depth_now[:, a]).to_dict() for a, name in enumerate(("front", "rear"))
    }
    for limit in LIMITS_MM:
        km = np.min((depth_now - limit) / np.maximum(per_km, 1e-12), axis=1)
        key = f"km_to_{limit:g}mm".replace(".", "_")
        out[key] = {
            **summarize(np.maximum(km, 0.0)).to_dict(),
            "already_below": bool(np.mean(km < 0) > 0.5),
        }
    ahead = np.linspace(0.0, horizon_km, 13)
    lowest = np.min(depth_now[:, None, :] - per_km[:, None, :] * ahead[None, :, None], axis=2)
    q = np.quantile(lowest, (0.05, 0.5, 0.95), axis=0)
    out["depth_curve"] = {
        "km_ahead": ahead.tolist(),
        "q05_mm": q[0].tolist(),
        "q50_mm": q[1].tolist(),
        "q95_mm": q[2].tolist(),
    }
    grams = 2.0 * 1000.0 * per_km.sum(axis=1) * geom.wear_area_mm2
    grams = grams * geom.rubber_density_g_per_cm3 / 1000.0  # car set, per 1000 km
    reference = reference_wear_g_per_1000km(tyre_type)
    out["g_per_1000km_car_set"] = summarize(grams).to_dict()
    out["wear_over_reference"] = {
        **summarize(grams / reference).to_dict(),
        "reference_g_per_1000km": reference,
        "tyre_type": tyre_type,
    }
    changes = history.changes
    out["tyre_changes"] = [
        {
            "drive_index": int(k),
            "odometer_km": float(history.odometer_km[k]),
            "kind": kind,
            "probability": float(p),
        }
        for k, kind, p in zip(changes.index, changes.kind, changes.probability, strict=True)
    ]
    out["n_drives"] = history.n_drives
    out["history_km"] = history.total_km
    return out, grams / reference
