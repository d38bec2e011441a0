"""Builders: fits in, report sections (numbers and arrays) out.

Each builder computes what its section states — posterior bands, OLS line and R², predictive
V_max, verdicts — from :class:`~tyrebayes.inference.result.Fit` objects (made in memory, or
loaded from what ``fit-tyre --out`` and ``fit-fleet --out`` write). Diagnostics are the fits' own
(:func:`~tyrebayes.inference.result.diagnose`): the report computes none.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import decisions
from .._domain import SURFACES, TYRE_TYPES
from ..inference.fleet import fit_summary, predict_friction
from ..inference.ols import fit_ols, ols_interval
from ..inference.result import Diagnostics, Fit
from ..inference.summary import summarize
from ..physics.thermal import stiffness_with_sensitivity
from ..physics.tyre import (
    brush_longitudinal,
    magic_formula_inverse_and_slope,
    shaped_longitudinal_inverse_and_slope,
)
from .content import FleetSection, LateralSection, TyreSection

#: Posterior draws used for the drawn curves and bands (a band needs a few hundred, not 4000).
CURVE_DRAWS = 400
#: Points on the slip / stiffness grids of the curves.
GRID_POINTS = 60
#: Central interval of the drawn bands.
BAND = (0.05, 0.5, 0.95)


def _flat(data, name: str) -> np.ndarray:
    v = np.asarray(data["posterior"][name])
    return v.reshape((-1,) + v.shape[2:])


def _shaped_curves(slip, c_x, mu, shape, curvature=None) -> np.ndarray:
    """ρ(σ) on the slip grid for each draw of the shaped or Magic Formula model (draws × grid).

    The model gives slip as a function of force; each draw's curve is traced over forces up to
    the peak and read at the grid by interpolation (flat at ±μ beyond the peak slip). With
    ``curvature`` the curve is the Magic Formula (shape C, curvature E), else the shaped family
    (exponent p).
    """
    c_x, mu, shape = (np.asarray(v, float)[:, None] for v in (c_x, mu, shape))
    rho = mu * np.linspace(-1.0, 1.0, 401)[None, :]
    if curvature is None:
        traced = np.asarray(shaped_longitudinal_inverse_and_slope(rho, c_x, mu, shape)[0])
    else:
        curvature = np.asarray(curvature, float)[:, None]
        traced = np.asarray(magic_formula_inverse_and_slope(rho, c_x, mu, shape, curvature)[0])
    return np.stack([np.interp(slip, t, r) for t, r in zip(traced, rho, strict=True)])


def _thin(n: int, k: int = CURVE_DRAWS) -> np.ndarray:
    return np.linspace(0, n - 1, min(n, k)).astype(int)


def diagnostics_row(diagnostics: Diagnostics, name: str | None = None) -> dict:
    """A fit's diagnostics as the report lists them (one row form for every kind of fit)."""
    d = diagnostics.as_dict()
    row = {
        "method": d["method"],
        "chains": d["n_chains"],
        "r_hat_max": d["r_hat_max"],
        "ess_min": diagnostics.ess_min,
        "divergences": d["divergences"],
        "converged": d["converged"],
        "reason": diagnostics.reason,
        "adequate": d["adequate"],
        "adequacy_reasons": d["adequacy_reasons"],
    }
    return row if name is None else {"fit": name, **row}


def tyre_section(
    fit: Fit,
    name: str,
    *,
    tyre_type: str | None = None,
    truth: dict | None = None,
    source: str = "",
) -> TyreSection:
    """Force–slip data and posterior curve bands of one per-tyre fit (``fit.kind == "tyre"``).

    ``constant_data`` may hold ``drive_index``/``surface_index`` per window (the demo writes
    them); without them the data are corrected by the mean offset over drives and assigned to
    the first surface.
    """
    if fit.kind != "tyre":
        raise ValueError(f"fit: expected a tyre fit, got a {fit.kind} fit")
    idata = fit.data
    post = idata["posterior"]
    surfaces = tuple(str(s) for s in np.atleast_1d(post["mu_max"].coords["surface"].values))
    win = _tyre_windows(idata)
    slip_c, rho_c = _corrected_windows(idata, win)
    c_x = _flat(idata, "c_x")
    mu = _flat(idata, "mu_max").reshape(c_x.shape[0], -1)
    curve = {
        s: _surface_curve(idata, win, slip_c, i, c_x, mu[:, i]) for i, s in enumerate(surfaces)
    }
    return TyreSection(
        name=name,
        tyre_type=tyre_type,
        surfaces=surfaces,
        slip=slip_c,
        rho=rho_c,
        window_surface=win.surface_index,
        at_limit=win.at_limit,
        curve=curve,
        summary=_tyre_summary(idata, c_x, mu, surfaces, win),
        diagnostics=diagnostics_row(fit.diagnostics),
        truth=truth,
        source=source,
    )


@dataclasses.dataclass(frozen=True)
class _TyreWindows:
    """A tyre fit's windows as observed: slip and ρ [-], ABS flags, drive and surface indices
    (``drive_index`` None: not in the file), tyre temperature [°C] (None: not in the file)."""

    slip: np.ndarray
    rho: np.ndarray
    at_limit: np.ndarray
    drive_index: np.ndarray | None
    surface_index: np.ndarray
    temperature_c: np.ndarray | None


def _tyre_windows(idata) -> _TyreWindows:
    """The observed windows of a tyre fit's data, with defaults for what the file lacks."""
    slip = np.asarray(idata["observed_data"]["slip_obs"], float)
    rho = np.asarray(idata["observed_data"]["rho_obs"], float)
    n_win = slip.size
    const = idata["constant_data"] if "constant_data" in idata.children else {}
    at_limit = np.asarray(const["at_limit"], bool) if "at_limit" in const else np.zeros(n_win, bool)
    drive = np.asarray(const["drive_index"], int) if "drive_index" in const else None
    surf_idx = (
        np.asarray(const["surface_index"], int)
        if "surface_index" in const
        else np.zeros(n_win, int)
    )
    temps = np.asarray(const["temperature_c"], float) if "temperature_c" in const else None
    return _TyreWindows(slip, rho, at_limit, drive, surf_idx, temps)


def _per_window(idata, win: _TyreWindows, name: str, default: float) -> np.ndarray:
    """Posterior mean of a per-drive nuisance at each window (the mean without indices)."""
    n_win = win.slip.size
    if name not in idata["posterior"]:
        return np.full(n_win, default)
    v = np.atleast_1d(_flat(idata, name).mean(axis=0))
    drive = win.drive_index
    if drive is None or v.size <= int(drive.max(initial=0)):
        return np.full(n_win, float(v.mean()))
    return v[drive]


def _corrected_windows(idata, win: _TyreWindows) -> tuple[np.ndarray, np.ndarray]:
    """(slip, ρ) of the windows with the posterior mean offsets and gain taken out.

    Offsets and gains of the per-tyre model versions: slip offset s0 (all), force gain g
    (slip-on-force model: rho_obs = g rho_true) or force offset b (force-on-slip model).
    """
    slip_c = win.slip - _per_window(idata, win, "slip_offset", 0.0)
    rho_c = win.rho / _per_window(idata, win, "force_gain", 1.0) - _per_window(
        idata, win, "rho_offset", 0.0
    )
    return slip_c, rho_c


def _surface_curve(
    idata, win: _TyreWindows, slip_c: np.ndarray, i: int, c_x: np.ndarray, mu: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(slip grid, 5 %, 50 %, 95 % of ρ there) of surface ``i``'s posterior curves.

    The grid spans the surface's corrected slips (all surfaces' without ABS-free windows of
    its own); C_x is taken at the surface's mean tyre temperature where the fit has a
    temperature sensitivity. ``mu``: μ_max draws on this surface.
    """
    post = idata["posterior"]
    use = ~win.at_limit
    sel = use & (win.surface_index == i)
    c_s = c_x
    # C_x at this surface's tyre temperature when the fit says what that was
    if (
        win.temperature_c is not None
        and "temp_sensitivity" in post
        and (win.surface_index == i).any()
    ):
        t_s = float(win.temperature_c[win.surface_index == i].mean())
        kappa = _flat(idata, "temp_sensitivity")
        c_s = np.asarray(stiffness_with_sensitivity(_flat(idata, "c_xr"), t_s, kappa))
    pts = slip_c[sel] if sel.any() else slip_c[use]
    lo = min(float(np.quantile(pts, 0.005)), -0.002) if pts.size else -0.01
    hi = max(float(np.quantile(pts, 0.995)), 0.004) if pts.size else 0.02
    grid = np.linspace(lo * 1.15, hi * 1.15, GRID_POINTS)
    idx = _thin(c_x.shape[0])
    if "curve_shape_c" in post:
        f = _shaped_curves(
            grid,
            c_s[idx],
            mu[idx],
            _flat(idata, "curve_shape_c")[idx],
            _flat(idata, "curve_curvature_e")[idx],
        )
    elif "curve_shape" in post:
        f = _shaped_curves(grid, c_s[idx], mu[idx], _flat(idata, "curve_shape")[idx])
    else:
        slide = _flat(idata, "mu_slide_ratio") if "mu_slide_ratio" in post else np.ones_like(c_x)
        f = np.asarray(
            brush_longitudinal(grid[None, :], c_s[idx, None], mu[idx, None], slide[idx, None])
        )
    q = np.quantile(f, BAND, axis=0)
    return (grid, q[0], q[1], q[2])


def _tyre_summary(idata, c_x, mu, surfaces, win: _TyreWindows) -> dict:
    """The section's numbers: C_x, C_xr, μ_max per surface, slip offset, window counts, κ."""
    post = idata["posterior"]
    summary = {
        "c_x": summarize(c_x).to_dict(),
        "c_xr": summarize(_flat(idata, "c_xr")).to_dict(),
        "mu_max": {s: summarize(mu[:, i]).to_dict() for i, s in enumerate(surfaces)},
        "slip_offset": (
            summarize(_flat(idata, "slip_offset").reshape(c_x.shape[0], -1)[:, 0]).to_dict()
            if "slip_offset" in post
            else None
        ),
        "n_windows": int(win.slip.size),
        "n_abs_windows": int(win.at_limit.sum()),
    }
    if "temp_sensitivity" in post:
        summary["temp_sensitivity"] = summarize(_flat(idata, "temp_sensitivity")).to_dict()
    return summary


def lateral_section(lateral, name: str) -> LateralSection:
    """Each axle's force–slip-angle samples and posterior curve band of a ``LateralFit``."""
    data = lateral.fit.data
    const = data["constant_data"]
    idx = _thin(lateral.draws("c_y_front").shape[0])
    mu = lateral.draws("mu_y")[idx]
    rho, alpha, curve = {}, {}, {}
    for axle in ("front", "rear"):
        rho[axle] = np.asarray(const[f"rho_{axle}"], float)
        alpha[axle] = np.asarray(const[f"alpha_{axle}_partial"], float)
        edge = max(float(np.quantile(np.abs(alpha[axle]), 0.995)), 0.01) * 1.15
        grid = np.linspace(-edge, edge, GRID_POINTS)
        c_y = lateral.draws(f"c_y_{axle}")[idx]
        shape, curvature = lateral.curve_shape(axle)
        f = _shaped_curves(grid, c_y, mu, shape[idx], curvature[idx])
        q = np.quantile(f, BAND, axis=0)
        curve[axle] = (grid, q[0], q[1], q[2])
    return LateralSection(name=name, rho=rho, alpha=alpha, curve=curve, summary=lateral.to_dict())


def fleet_section(
    fit: Fit, *, surface: str | None = None, seed: int = 0, source: str = ""
) -> FleetSection:
    """Friction vs 1/C_xr (thesis Fig. 6.2): data, hierarchical predictive bands, OLS line, R².

    Bands: :func:`tyrebayes.inference.fleet.predict_friction` of a new set of each type at exact
    stiffness over the type's observed range; OLS: the thesis' line fitted to all sets of the
    surface with its 90 % prediction interval.
    """
    fitted = fit.attr("fitted_surfaces")
    surface = surface or ("snow" if "snow" in fitted else fitted[0])
    outcome = str(fit.data.attrs["outcome"])
    const = fit.data["constant_data"]
    rows = np.asarray(const["row_surface"]) == SURFACES.index(surface)
    tyre = np.asarray(const["row_tyre"])[rows]
    c_xr = np.asarray(const["c_xr_obs"], float)[tyre]
    c_sd = np.asarray(const["c_xr_sd"], float)[tyre]
    mu = np.asarray(fit.data["observed_data"][outcome], float)[rows]
    types = np.array([TYRE_TYPES[i] for i in np.asarray(const["row_type"])[rows]])
    bands = {}
    for t in TYRE_TYPES:
        sel = types == t
        if not sel.any():
            continue
        lo, hi = float(c_xr[sel].min()), float(c_xr[sel].max())
        grid = np.linspace(lo * 0.92, hi * 1.08, 30)
        draws = np.stack(
            [predict_friction(fit, float(c), 0.0, t, surface, seed=seed) for c in grid]
        )
        q = np.quantile(draws, BAND, axis=1)
        bands[t] = (grid, q[0], q[1], q[2])
    ols = fit_ols(c_xr, mu)
    grid = np.linspace(float(c_xr.min()) * 0.92, float(c_xr.max()) * 1.08, GRID_POINTS)
    mid, lo, hi = ols_interval(ols, grid, 0.9)
    summary = fit_summary(fit)
    return FleetSection(
        surface=surface,
        outcome=outcome,
        c_xr=c_xr,
        c_xr_sd=c_sd,
        mu=mu,
        tyre_type=types,
        bands=bands,
        ols={
            "intercept": ols.intercept,
            "slope": ols.slope,
            "r2": ols.r2,
            "resid_sd": ols.resid_sd,
            "n": ols.n_obs,
            "band": (grid, np.asarray(lo), np.asarray(mid), np.asarray(hi)),
        },
        parameters=summary["parameters"].get(surface, {}),
        diagnostics=diagnostics_row(fit.diagnostics),
        n_sets=int(rows.sum()),
        source=source,
    )


def warning_rows(fleet: Fit, tyres: list[TyreSection], *, seed: int = 0) -> list[dict]:
    """Winter-suitability verdict per tyre set of known type (snow, default μ_min and costs)."""
    out = []
    for k, t in enumerate(tyres):
        c = t.summary["c_xr"]
        draws = predict_friction(
            fleet, float(c["mean"]), float(c["sd"]), t.tyre_type, "snow", seed=seed + k
        )
        v = decisions.winter_verdict(draws)
        out.append(
            {
                "decision": "winter suitability",
                "subject": t.name,
                "tyre_type": t.tyre_type or "unknown",
                "c_xr": c,
                "quantity": "mu on snow",
                "predicted": v.mu,
                "interval_90": v.interval_90,
                "event": f"mu < {v.mu_min:.2f}",
                "probability": v.probability,
                "threshold": v.threshold,
                "verdict": v.verdict,
                "reason": v.reason,
            }
        )
    return out


def criticism_entry(title: str, result) -> dict:
    """A criticism result as the report lists it: baseline, top candidates, findings, notes."""
    cands = [
        {
            "covariate": c.covariate + (f" ({c.level})" if c.level else ""),
            "q_value": float(c.q_value),
            "elpd_gain": float(c.elpd_gain),
            "se": float(c.se),
            "effect": c.effect,
            "found": bool(c.found),
        }
        for c in result.candidates
    ]
    return {
        "title": title,
        "baseline": {"elpd": float(result.baseline.elpd), "se": float(result.baseline.se)},
        "candidates": cands,
        "found": list(result.found),
        "ppc": dict(result.ppc),
        "notes": list(result.notes),
    }
