"""Synthetic fleet tables with known truth and switchable hidden effects.

A fleet table (DESIGN.md contract) has one row per tyre set and surface: ``tyre_id``, ``tyre_type``
(``winter``, ``all_season``, ``summer``), the observed compensated stiffness ``c_xr`` with its
standard error ``c_xr_sd``, the outcome ``mu`` (friction potential, thesis eq. 3.3), ``surface``,
and numeric candidate covariates (``age_years``, ``tread_depth_mm``, ``pressure_bar``,
``load_index``, ``decoy_1`` ...).

Generative model (per tyre set *i* of type *t*, surface *s*)::

    C_true_i  ~ LogNormal(type median, type log-sd)     (winter ~30, all-season ~40, summer ~55)
    C_true_i *= 1 + stiffening(hidden effects)               (aged / loaded rubber is stiffer)
    z_i       = 100 / C_true_i - 100 / C_med[t]              (inverse stiffness, thesis Fig 6.1,
                                                              centred at the type's median)
    mu_is     = a[t,s] + b[t,s] * z_i + hidden(covariates) + sigma[t,s] * eps
    c_xr_i    = C_true_i + c_xr_sd_i * eta                   (stiffness estimate with its error)

The type-level numbers are chosen to agree with the measured braking data
(``tyrebayes/data/braking_by_tyre_type.csv``; mean deceleration v^2 / (2 g d) is a lower bound on
mu_max): on snow winter tyres decelerate at 0.34-0.45 g, summer tyres at < 0.18 g; on ice
0.12-0.15 g (winter) vs 0.08 g (summer); wet 0.71-0.85 g; dry 0.90 g (winter) - 1.11 g (summer).
Peak friction is set ~5-10 % above these means (ABS braking runs around, not at, the peak).
Within a type softer tyres grip better on snow and ice (thesis Fig 6.1: mu rises with 1/C_xr).

Hidden effects (``effects=``) and the meaning of ``effect_size`` (natural units):

``"age"``
    Aged rubber hardens: mu on snow and ice drops by ``effect_size`` per year of ``age_years``
    above :data:`AGE_REF_YEARS` (beyond what the stiffness explains) and the true stiffness rises
    by ``AGE_STIFFENING_PER_YEAR * effect_size / THESIS_AGED_TYRE_EFFECT`` per year (relative).
    Ages are 0.5 + Gamma(2, 1.4) years (mean ~3.3, a tail past the 5-year lifetime).
    :data:`THESIS_AGED_TYRE_EFFECT` (0.04 per year) reproduces the thesis' two over-aged winter
    tyres (Sec. 6.1): at 7 years a typical winter set (C_xr 30, mu 0.45) is ~24 % stiffer
    (C_xr ~37) and loses 0.16 + 0.06 (via stiffness) of snow mu, ending at ~0.23, i.e. "as bad
    as the summer tyres" (~0.18).
``"load"``
    Mu drops by ``effect_size`` per 10 load-index points above :data:`LOAD_INDEX_REF` (load
    sensitivity of rubber friction) and stiffness rises 2 % per 10 points. Default
    :data:`DEFAULT_EFFECT_SIZES` ``["load"] = 0.04``.
``"pressure"``
    Mu drops by ``effect_size`` per bar above :data:`PRESSURE_REF_BAR` (smaller contact patch);
    stiffness unchanged. Default 0.08 per bar.
``"tread"``
    Mu rises by ``effect_size`` per mm of ``tread_depth_mm`` above :data:`TREAD_REF_MM` (deeper
    tread packs and bites more snow); stiffness unchanged. Default 0.012 per mm (the weak effect of
    issue 25).

Lateral estimates (``lateral_ratio=``): each set's ratio k_i = c_y / C_xr is drawn from its type's
log-normal population, ``log k_i ~ Normal(log k_type, k_log_sd)``, and a share of the sets gets a
measured ``c_y`` = k_i · C_true_i · exp(s_i · eps) with ``c_y_sd`` = s_i · c_y, s_i uniform in
``c_y_log_sd`` (the per-drive lateral fits' relative sds are 0.1-0.15,
``benchmarks/results/lateral_external.json``; a set of several drives is tighter). Sets without
one have empty ``c_y`` and ``c_y_sd`` (driven only straight).

On dry and wet roads the hidden effects act at a quarter of their size (the thesis' effect is a
winter phenomenon); they never act on the covariates' distribution, only on mu and stiffness.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import jax
import numpy as np
import pandas as pd

from .._domain import SURFACES, TYRE_TYPES

#: Reference stiffness for centring: z = 100 / C_xr - 100 / C_XR_REF (z = 0 at C_xr = 40).
C_XR_REF: float = 40.0
#: Scale of the inverse stiffness: z is in units of 100 / C_xr.
X_SCALE: float = 100.0

#: mu drop on snow per year of tyre age that reproduces the thesis' over-aged winter tyres.
THESIS_AGED_TYRE_EFFECT: float = 0.04
#: Relative stiffening per year of age at the thesis effect size (7 vs 3 years -> +24 %).
AGE_STIFFENING_PER_YEAR: float = 0.06
#: Typical tyre age at which the age effect is zero (type-level numbers describe such a tyre).
AGE_REF_YEARS: float = 3.0
LOAD_INDEX_REF: float = 91.0
PRESSURE_REF_BAR: float = 2.4
TREAD_REF_MM: float = 6.0
#: Default effect sizes (natural units, see module docstring).
DEFAULT_EFFECT_SIZES: Mapping[str, float] = {
    "age": THESIS_AGED_TYRE_EFFECT,
    "load": 0.04,
    "pressure": 0.08,
    "tread": 0.012,
}
HIDDEN_EFFECTS: tuple[str, ...] = tuple(DEFAULT_EFFECT_SIZES)
# Relative strength of the hidden effects on high-friction surfaces.
_HIGH_FRICTION_EFFECT_SHARE = 0.25

#: Type-level stiffness distribution: (median C_xr, log-sd). Thesis Fig 6.1 / chapter 3:
#: winter sets soft (~25-35), summer stiff (~45-65), all-season between.
TYPE_STIFFNESS: Mapping[str, tuple[float, float]] = {
    "winter": (30.0, 0.10),
    "all_season": (40.0, 0.10),
    "summer": (55.0, 0.10),
}

#: Type-level friction model per surface: (a, b, sigma). ``a`` is mu of a set of the type at its
#: median stiffness (``TYPE_STIFFNESS``), ``b`` = d mu / d z (z in units of 100 / C_xr), ``sigma``
#: the residual sd. Values follow the braking data (module docstring); slopes follow thesis Fig 6.1
#: on snow (softer grips better), are smaller on ice and about flat on wet/dry.
TYPE_FRICTION: Mapping[str, Mapping[str, tuple[float, float, float]]] = {
    "snow": {
        "winter": (0.45, 0.10, 0.030),
        "all_season": (0.42, 0.08, 0.030),
        "summer": (0.18, 0.05, 0.025),
    },
    "ice": {
        "winter": (0.15, 0.04, 0.015),
        "all_season": (0.13, 0.03, 0.015),
        "summer": (0.09, 0.02, 0.012),
    },
    "wet": {
        "winter": (0.78, 0.02, 0.040),
        "all_season": (0.80, 0.02, 0.040),
        "summer": (0.85, 0.02, 0.040),
    },
    "dry": {
        "winter": (0.95, -0.05, 0.050),
        "all_season": (1.05, -0.05, 0.050),
        "summer": (1.15, -0.05, 0.050),
    },
}

#: Default share of tyre types in a fleet (the thesis' winter tests: mostly winter sets).
DEFAULT_TYPE_SHARES: Mapping[str, float] = {"winter": 0.6, "all_season": 0.15, "summer": 0.25}


def inverse_stiffness(c_xr):
    """Centred inverse stiffness z = 100 / C_xr - 100 / C_XR_REF (thesis Fig 6.1 abscissa).

    Parameters
    ----------
    c_xr : array_like
        Compensated longitudinal stiffness C_xr (dimensionless, > 0).

    Returns
    -------
    array_like
        z, zero at C_xr = 40, positive for softer tyres.

    Examples
    --------
    >>> round(float(inverse_stiffness(40.0)), 6)
    0.0
    """
    return X_SCALE / c_xr - X_SCALE / C_XR_REF


def _rng(key_or_seed) -> np.random.Generator:
    if isinstance(key_or_seed, int | np.integer):
        return np.random.default_rng(int(key_or_seed))
    key = jax.numpy.asarray(key_or_seed)
    if jax.dtypes.issubdtype(key.dtype, jax.dtypes.prng_key):
        key = jax.random.key_data(key)
    return np.random.default_rng(np.asarray(key, dtype=np.uint32).ravel().tolist())


def _type_counts(n_sets: int, shares: Mapping[str, float]) -> dict[str, int]:
    """Deterministic counts per type, at least 2 per type with a positive share when n_sets >= 6."""
    types = [t for t in TYRE_TYPES if shares.get(t, 0.0) > 0]
    total = sum(shares[t] for t in types)
    counts = {t: int(np.floor(n_sets * shares[t] / total)) for t in types}
    if n_sets >= 2 * len(types):
        for t in types:
            counts[t] = max(counts[t], 2)
    # Hand out (or take back) the remainder, largest share first.
    order = sorted(types, key=lambda t: -shares[t])
    i = 0
    while sum(counts.values()) < n_sets:
        counts[order[i % len(order)]] += 1
        i += 1
    while sum(counts.values()) > n_sets:
        t = order[i % len(order)]
        if counts[t] > 2:
            counts[t] -= 1
        i += 1
    return counts


def _effect_sizes(effects: Sequence[str], effect_size) -> dict[str, float]:
    unknown = [e for e in effects if e not in HIDDEN_EFFECTS]
    if unknown:
        raise ValueError(f"effects: expected names from {HIDDEN_EFFECTS}, got {unknown}")
    if effect_size is None:
        return {e: float(DEFAULT_EFFECT_SIZES[e]) for e in effects}
    if isinstance(effect_size, Mapping):
        return {e: float(effect_size.get(e, DEFAULT_EFFECT_SIZES[e])) for e in effects}
    return {e: float(effect_size) for e in effects}


def simulate_fleet(
    key_or_seed,
    n_sets: int,
    *,
    surface: str | Sequence[str] = "snow",
    effects: Sequence[str] = (),
    effect_size: float | Mapping[str, float] | None = None,
    n_decoys: int = 2,
    c_xr_sd: float = 1.5,
    type_shares: Mapping[str, float] | None = None,
    noise: str = "gaussian",
    lateral_ratio: Mapping[str, tuple[float, float]] | None = None,
    lateral_share: float = 1.0,
    c_y_log_sd: tuple[float, float] = (0.06, 0.15),
) -> tuple[pd.DataFrame, dict]:
    """Simulate a fleet table with known type-level truth.

    Parameters
    ----------
    key_or_seed : int or jax PRNG key
        Seed of the simulation (a JAX key is turned into a NumPy seed).
    n_sets : int
        Number of tyre sets (>= 1).
    surface : str or sequence of str
        ``"snow"``, ``"ice"``, ``"wet"``, ``"dry"`` or several (one row per set and surface).
    effects : sequence of str
        Hidden effects to switch on: ``"age"``, ``"load"``, ``"pressure"``, ``"tread"`` (module
        docstring).
    effect_size : float, mapping or None
        Size of each hidden effect in its natural unit (mu per year / per 10 load-index points /
        per bar / per mm). ``None`` uses :data:`DEFAULT_EFFECT_SIZES` (age:
        :data:`THESIS_AGED_TYRE_EFFECT`).
    n_decoys : int
        Number of pure-noise numeric columns ``decoy_1`` ... (no effect on anything).
    c_xr_sd : float
        Typical standard error of the stiffness estimate (per-row values vary by +-30 %).
    type_shares : mapping or None
        Share of each tyre type; default :data:`DEFAULT_TYPE_SHARES`.
    noise : {"gaussian", "student_t3"}
        Distribution of the friction residuals: Gaussian, or Student-t with 3 degrees of freedom
        scaled to the same sd (heavier tails: the departure a criticism must not call a finding).
    lateral_ratio : mapping or None
        Per type ``(median k, log-sd of k)`` of the ratio c_y / C_xr (module docstring); None
        (default) adds no lateral columns.
    lateral_share : float
        Share of the sets with a lateral estimate (the first ones in id order after shuffling:
        a random subset), in [0, 1].
    c_y_log_sd : (float, float)
        Range of the sets' relative measurement error of c_y.

    Returns
    -------
    table : pandas.DataFrame
        Fleet table in the DESIGN.md contract.
    truth : dict
        ``type_params`` {surface: {type: {"a", "b", "sigma"}}}, ``c_xr_true`` (per set),
        ``effects`` {name: size}, ``effect_columns`` {name: column}, ``decoys``, ``c_xr_ref``,
        ``x_scale``, ``stiffness`` {type: (median, log_sd)}; with ``lateral_ratio`` also
        ``lateral_ratio`` (as given), ``k_true`` and ``c_y_true`` per set, ``has_lateral`` (bool
        per set).

    Examples
    --------
    >>> table, truth = simulate_fleet(0, 26)
    >>> sorted(table["tyre_type"].unique())
    ['all_season', 'summer', 'winter']
    """
    surfaces = _checked_surfaces(n_sets, c_xr_sd, noise, surface)
    sizes = _effect_sizes(tuple(effects), effect_size)
    shares = dict(DEFAULT_TYPE_SHARES if type_shares is None else type_shares)
    rng = _rng(key_or_seed)
    # Decoys get their own stream so adding decoys leaves every other column unchanged.
    decoy_rng = np.random.default_rng(rng.integers(2**62))

    counts = _type_counts(n_sets, shares)
    types = np.array([t for t in TYRE_TYPES for _ in range(counts.get(t, 0))])
    rng.shuffle(types)
    n = len(types)
    covariates = _covariates(rng, n)
    decoys = decoy_rng.normal(0.0, 1.0, (n, n_decoys))

    median = np.array([TYPE_STIFFNESS[t][0] for t in types])
    log_sd = np.array([TYPE_STIFFNESS[t][1] for t in types])
    c_true = median * np.exp(log_sd * rng.normal(size=n))
    stiffening, mu_shift = _hidden_effects(sizes, covariates)
    c_true = c_true * np.maximum(1.0 + stiffening, 0.5)
    z_true = inverse_stiffness(c_true) - inverse_stiffness(median)

    sd_row = c_xr_sd * rng.uniform(0.7, 1.3, n)
    c_obs = np.maximum(c_true + sd_row * rng.normal(size=n), 1.0)

    frames = []
    for s in surfaces:
        mu = _friction(rng, s, types, z_true, mu_shift, noise)
        frames.append(_surface_rows(s, types, c_obs, sd_row, mu, covariates, decoys))
    table = pd.concat(frames, ignore_index=True)
    truth = _truth(surfaces, c_true, sizes, n_decoys, counts)
    if lateral_ratio is not None:
        lateral = _lateral_estimates(rng, types, c_true, lateral_ratio, lateral_share, c_y_log_sd)
        table["c_y"] = np.tile(lateral["c_y"], len(surfaces))
        table["c_y_sd"] = np.tile(lateral["c_y_sd"], len(surfaces))
        truth.update(
            lateral_ratio=dict(lateral_ratio),
            k_true=lateral["k_true"],
            c_y_true=lateral["k_true"] * c_true,
            has_lateral=lateral["has"],
        )
    return table, truth


def _checked_surfaces(n_sets: int, c_xr_sd: float, noise: str, surface) -> tuple[str, ...]:
    """The surfaces asked for, as a tuple, once the options are checked (ValueError naming
    expected vs got)."""
    if n_sets < 1:
        raise ValueError(f"n_sets: expected >= 1, got {n_sets}")
    if c_xr_sd < 0:
        raise ValueError(f"c_xr_sd: expected >= 0, got {c_xr_sd}")
    if noise not in ("gaussian", "student_t3"):
        raise ValueError(f"noise: expected 'gaussian' or 'student_t3', got {noise!r}")
    surfaces = (surface,) if isinstance(surface, str) else tuple(surface)
    bad = [s for s in surfaces if s not in SURFACES]
    if bad or not surfaces:
        raise ValueError(f"surface: expected names from {SURFACES}, got {list(surfaces)}")
    return surfaces


def _covariates(rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
    """The candidate covariates per set, by column (unrounded): always present, effective
    only when their hidden effect is switched on."""
    return {
        "age_years": np.minimum(0.5 + rng.gamma(2.0, 1.4, n), 15.0),
        "tread_depth_mm": rng.uniform(3.0, 9.0, n),
        "pressure_bar": rng.uniform(1.9, 3.0, n),
        "load_index": rng.integers(82, 101, n).astype(float),
    }


def _hidden_effects(
    sizes: Mapping[str, float], covariates: Mapping[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Per set the relative stiffening and the mu shift (its snow and ice size) of the hidden
    effects switched on (module docstring)."""
    n = len(covariates["age_years"])
    stiffening = np.zeros(n)
    mu_shift = np.zeros(n)  # snow/ice size; scaled on dry/wet
    if "age" in sizes:
        years = covariates["age_years"] - AGE_REF_YEARS
        stiffening += AGE_STIFFENING_PER_YEAR * sizes["age"] / THESIS_AGED_TYRE_EFFECT * years
        mu_shift -= sizes["age"] * years
    if "load" in sizes:
        load = covariates["load_index"] - LOAD_INDEX_REF
        stiffening += 0.02 * load / 10.0
        mu_shift -= sizes["load"] * load / 10.0
    if "pressure" in sizes:
        mu_shift -= sizes["pressure"] * (covariates["pressure_bar"] - PRESSURE_REF_BAR)
    if "tread" in sizes:
        mu_shift += sizes["tread"] * (covariates["tread_depth_mm"] - TREAD_REF_MM)
    return stiffening, mu_shift


def _friction(
    rng: np.random.Generator,
    surface: str,
    types: np.ndarray,
    z_true: np.ndarray,
    mu_shift: np.ndarray,
    noise: str,
) -> np.ndarray:
    """Per set its mu on ``surface``: the type's line in the inverse stiffness, the hidden
    effects (a quarter of their size on dry and wet) and the residual (unclipped)."""
    a = np.array([TYPE_FRICTION[surface][t][0] for t in types])
    b = np.array([TYPE_FRICTION[surface][t][1] for t in types])
    sig = np.array([TYPE_FRICTION[surface][t][2] for t in types])
    share = 1.0 if surface in ("snow", "ice") else _HIGH_FRICTION_EFFECT_SHARE
    n = len(types)
    eps = (
        rng.normal(size=n)
        if noise == "gaussian"
        else rng.standard_t(3.0, size=n) / np.sqrt(3.0)  # var of t_3 is 3
    )
    return a + b * z_true + share * mu_shift + sig * eps


def _surface_rows(
    surface: str,
    types: np.ndarray,
    c_obs: np.ndarray,
    sd_row: np.ndarray,
    mu: np.ndarray,
    covariates: Mapping[str, np.ndarray],
    decoys: np.ndarray,
) -> pd.DataFrame:
    """The table's rows of one surface, one per set, in the contract's column order."""
    frame = pd.DataFrame(
        {
            "tyre_id": [f"T{i:05d}" for i in range(len(types))],
            "tyre_type": types,
            "surface": surface,
            "c_xr": c_obs,
            "c_xr_sd": sd_row,
            "mu": np.clip(mu, 0.02, None),
            "age_years": np.round(covariates["age_years"], 2),
            "tread_depth_mm": np.round(covariates["tread_depth_mm"], 2),
            "pressure_bar": np.round(covariates["pressure_bar"], 3),
            "load_index": covariates["load_index"],
        }
    )
    for j in range(decoys.shape[1]):
        frame[f"decoy_{j + 1}"] = decoys[:, j]
    return frame


def _truth(
    surfaces: tuple[str, ...],
    c_true: np.ndarray,
    sizes: dict[str, float],
    n_decoys: int,
    counts: dict[str, int],
) -> dict:
    """The simulation's truth (:func:`simulate_fleet`'s ``truth``, without the lateral part)."""
    return {
        "type_params": {
            s: {
                t: dict(zip(("a", "b", "sigma"), TYPE_FRICTION[s][t], strict=True))
                for t in TYRE_TYPES
            }
            for s in surfaces
        },
        "c_xr_true": c_true,
        "effects": sizes,
        "effect_columns": {
            "age": "age_years",
            "load": "load_index",
            "pressure": "pressure_bar",
            "tread": "tread_depth_mm",
        },
        "decoys": [f"decoy_{j + 1}" for j in range(n_decoys)],
        "c_xr_ref": C_XR_REF,
        "x_scale": X_SCALE,
        "stiffness": dict(TYPE_STIFFNESS),
        "type_counts": counts,
        "age_ref_years": AGE_REF_YEARS,
    }


def _lateral_estimates(rng, types, c_true, lateral_ratio, share, log_sd_range) -> dict:
    """Per set: true ratio, measured c_y and its sd (NaN without a lateral estimate)."""
    missing = [t for t in set(types) if t not in lateral_ratio]
    if missing:
        raise ValueError(
            f"lateral_ratio: expected (median, log_sd) for {sorted(missing)}, got none"
        )
    if not 0.0 <= share <= 1.0:
        raise ValueError(f"lateral_share: expected a share in [0, 1], got {share}")
    lo, hi = log_sd_range
    if not 0.0 < lo <= hi:
        raise ValueError(f"c_y_log_sd: expected 0 < low <= high, got {log_sd_range}")
    n = len(types)
    median = np.array([lateral_ratio[t][0] for t in types], float)
    spread = np.array([lateral_ratio[t][1] for t in types], float)
    k_true = median * np.exp(spread * rng.normal(size=n))
    s = rng.uniform(lo, hi, n)
    c_y = k_true * c_true * np.exp(s * rng.normal(size=n))
    has = np.arange(n) < int(round(share * n))
    return {
        "k_true": k_true,
        "c_y": np.where(has, c_y, np.nan),
        "c_y_sd": np.where(has, s * c_y, np.nan),
        "has": has,
    }
