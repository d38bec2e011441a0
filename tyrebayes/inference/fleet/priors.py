"""Priors of the fleet model per tyre type and surface (sources in ``models/priors``).

Also the prior predictive check of those numbers against the measured braking decelerations.
"""

from __future__ import annotations

from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pandas as pd

from ..._domain import SURFACES, TYRE_TYPES, load_braking_data, mean_deceleration_g, read_toml
from ..._errors import BadInputError
from ..._resources import models_dir


class FleetPriors(eqx.Module):
    """Prior numbers of the fleet model (see ``models/priors/tyre_types.toml`` for sources).

    Arrays are indexed ``[type]`` (order :data:`TYRE_TYPES`), ``[surface]`` (order
    :data:`SURFACES`) or ``[surface, type]``. Stiffness numbers are dimensionless C_xr; friction
    numbers are dimensionless mu; slopes are mu per unit of z = 100 / C_xr. The lateral ratio
    k = c_y / C_xr [1/rad per unit C_xr] has a per-type median ``k_ratio`` (prior uncertainty
    ``k_ratio_log_sd``, on the log scale) and a within-type log-sd ``k_spread`` (median of its
    log-normal prior).
    """

    c_xr_ref: np.ndarray
    c_xr_ref_log_sd: np.ndarray
    c_xr_log_sd: np.ndarray
    mu: np.ndarray
    mu_sd: np.ndarray
    slope: np.ndarray
    slope_sd: np.ndarray
    tau_slope: np.ndarray
    sigma: np.ndarray
    sigma_log_sd: np.ndarray
    tau_sigma: np.ndarray
    default_c_xr_sd: float
    k_ratio: np.ndarray
    k_ratio_log_sd: np.ndarray
    k_spread: np.ndarray

    def __check_init__(self):
        for name in (
            "c_xr_ref",
            "c_xr_ref_log_sd",
            "c_xr_log_sd",
            "mu_sd",
            "slope_sd",
            "k_ratio",
            "k_ratio_log_sd",
            "k_spread",
        ):
            value = np.asarray(getattr(self, name))
            if not np.all(value > 0):
                raise ValueError(f"{name}: expected > 0, got {value.tolist()}")
        for name in ("tau_slope", "sigma", "sigma_log_sd", "tau_sigma"):
            value = np.asarray(getattr(self, name))
            if not np.all(value > 0):
                raise ValueError(f"{name}: expected > 0, got {value.tolist()}")
        if not self.default_c_xr_sd > 0:
            raise ValueError(f"default_c_xr_sd: expected > 0, got {self.default_c_xr_sd}")


def load_tyre_type_priors(path: str | Path | None = None) -> FleetPriors:
    """Read the tyre-type priors (default ``models/priors/tyre_types.toml``).

    Examples
    --------
    >>> load_tyre_type_priors().c_xr_ref.tolist()
    [30.0, 40.0, 55.0]
    """
    path = Path(path) if path is not None else models_dir() / "priors" / "tyre_types.toml"
    raw = read_toml(path)
    try:
        types = [raw["types"][t] for t in TYRE_TYPES]
        surfs = [raw["surfaces"][s] for s in SURFACES]
        return FleetPriors(
            c_xr_ref=np.array([t["c_xr_ref"] for t in types], float),
            c_xr_ref_log_sd=np.array([t["c_xr_ref_log_sd"] for t in types], float),
            c_xr_log_sd=np.array([t["c_xr_log_sd"] for t in types], float),
            mu=np.array([[s[t]["mu"] for t in TYRE_TYPES] for s in surfs], float),
            mu_sd=np.array([[s[t]["mu_sd"] for t in TYRE_TYPES] for s in surfs], float),
            slope=np.array([s["slope"] for s in surfs], float),
            slope_sd=np.array([s["slope_sd"] for s in surfs], float),
            tau_slope=np.array([s["tau_slope"] for s in surfs], float),
            sigma=np.array([s["sigma"] for s in surfs], float),
            sigma_log_sd=np.array([s["sigma_log_sd"] for s in surfs], float),
            tau_sigma=np.array([s["tau_sigma"] for s in surfs], float),
            default_c_xr_sd=float(raw["default_c_xr_sd"]),
            k_ratio=np.array([t["k_ratio"] for t in types], float),
            k_ratio_log_sd=np.array([t["k_ratio_log_sd"] for t in types], float),
            k_spread=np.array([t["k_spread"] for t in types], float),
        )
    except KeyError as err:
        raise BadInputError(f"priors file {path}: expected key {err}, not found") from err


def prior_draws(priors: FleetPriors, n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Draws of the surface-level parameters from their priors, all four surfaces.

    Used for the surfaces a fleet table has no rows on. Shapes ``(n, 4, 3)`` for a, b, sigma and
    ``(n, 4)`` for slope, tau_slope, sigma0, tau_sigma.
    """
    rng = np.random.default_rng(seed)
    n_s, n_t = priors.mu.shape
    a = priors.mu + priors.mu_sd * rng.standard_normal((n, n_s, n_t))
    slope = priors.slope + priors.slope_sd * rng.standard_normal((n, n_s))
    tau_b = np.abs(priors.tau_slope * rng.standard_normal((n, n_s)))
    b = slope[..., None] + tau_b[..., None] * rng.standard_normal((n, n_s, n_t))
    log_s0 = np.log(priors.sigma) + priors.sigma_log_sd * rng.standard_normal((n, n_s))
    tau_s = np.abs(priors.tau_sigma * rng.standard_normal((n, n_s)))
    sigma = np.exp(log_s0[..., None] + tau_s[..., None] * rng.standard_normal((n, n_s, n_t)))
    return {
        "a": a,
        "b": b,
        "sigma": sigma,
        "slope": slope,
        "tau_slope": tau_b,
        "sigma0": np.exp(log_s0),
        "tau_sigma": tau_s,
    }


def prior_arrays(priors: FleetPriors, surfaces: np.ndarray) -> dict:
    per_type = (
        "c_xr_ref",
        "c_xr_ref_log_sd",
        "c_xr_log_sd",
        "k_ratio",
        "k_ratio_log_sd",
        "k_spread",
    )
    per_surface = (
        "mu",
        "mu_sd",
        "slope",
        "slope_sd",
        "tau_slope",
        "sigma",
        "sigma_log_sd",
        "tau_sigma",
    )
    out = {n: jnp.asarray(getattr(priors, n)) for n in per_type}
    out.update({n: jnp.asarray(np.asarray(getattr(priors, n))[surfaces]) for n in per_surface})
    return out


#: Average fraction of mu_max an ABS stop realises as mean deceleration (judgement, see TOML).
ABS_EFFICIENCY_RANGE: tuple[float, float] = (0.7, 1.0)


def measured_braking_bounds() -> pd.DataFrame:
    """Mean decelerations v^2 / (2 g d) from the shipped braking data, by type and surface.

    A stop's mean deceleration [g] is a lower bound on mu_max; the summer-on-snow row of What
    Car? gives only "more than twice the winter distance", i.e. an upper bound on its mean
    deceleration (``bound = "upper"``).
    """
    raw = load_braking_data()
    rows = []
    for _, r in raw.iterrows():
        if np.isfinite(r["distance_m"]):
            decel = float(mean_deceleration_g(r["speed_from_kmh"], r["distance_m"]))
            rows.append((r["source"], r["tyre_type"], r["surface"], decel, "lower"))
        elif "more than twice" in str(r["note"]):
            winter = raw[
                (raw.source == r.source) & (raw.surface == r.surface) & (raw.tyre_type == "winter")
            ]["distance_m"].iloc[0]
            decel = float(mean_deceleration_g(r["speed_from_kmh"], 2 * winter))
            rows.append((r["source"], r["tyre_type"], r["surface"], decel, "upper"))
    return pd.DataFrame(rows, columns=["source", "tyre_type", "surface", "deceleration_g", "bound"])


def prior_predictive_check(
    priors: FleetPriors | None = None, *, n_draws: int = 4000, seed: int = 0
) -> pd.DataFrame:
    """Prior predictive mu of a typical set of each type against the measured braking data.

    For every measured row, draws mu from the prior (type intercept + residual scatter at the
    type's reference stiffness) and compares it with the range of mu_max the measurement allows:
    ``[decel, decel / 0.7]`` for a lower bound (ABS realises 70-100 % of mu_max), ``[0, decel /
    0.7]`` for an upper bound. ``consistent`` is True when the prior's 90 % interval overlaps that
    range and its median lies within ``[0.8 * lo, 1.25 * hi]``.
    """
    priors = load_tyre_type_priors() if priors is None else priors
    rng = np.random.default_rng(seed)
    out = []
    for _, r in measured_braking_bounds().iterrows():
        s, t = SURFACES.index(r.surface), TYRE_TYPES.index(r.tyre_type)
        a = priors.mu[s, t] + priors.mu_sd[s, t] * rng.standard_normal(n_draws)
        sig = priors.sigma[s] * np.exp(priors.sigma_log_sd[s] * rng.standard_normal(n_draws))
        mu = a + sig * rng.standard_normal(n_draws)
        q05, q50, q95 = np.quantile(mu, [0.05, 0.5, 0.95])
        lo = r.deceleration_g / ABS_EFFICIENCY_RANGE[1] if r.bound == "lower" else 0.0
        hi = r.deceleration_g / ABS_EFFICIENCY_RANGE[0]
        consistent = bool(q05 <= hi and q95 >= lo and 0.8 * lo <= q50 <= 1.25 * hi)
        out.append(
            {
                **r.to_dict(),
                "allowed_lo": lo,
                "allowed_hi": hi,
                "prior_q05": q05,
                "prior_median": q50,
                "prior_q95": q95,
                "consistent": consistent,
            }
        )
    return pd.DataFrame(out)
