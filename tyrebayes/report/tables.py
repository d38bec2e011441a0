"""The report's tables as (header, rows of strings), shared by the HTML and Markdown writers."""

from __future__ import annotations

import math

from .content import Report


def fmt(x, digits: int = 3) -> str:
    """A number for a table: NaN/None as '–', else ``digits`` significant figures."""
    if x is None:
        return "–"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(v):
        return "–"
    return f"{v:.{digits}g}"


def post(s: dict, digits: int = 3) -> str:
    """``mean ± sd [lo, hi]`` of a posterior summary."""
    lo, hi = s["hdi_90"]
    return f"{fmt(s['mean'], digits)} ± {fmt(s['sd'], 2)} [{fmt(lo, digits)}, {fmt(hi, digits)}]"


Table = tuple[list[str], list[list[str]]]


def tyre_table(report: Report) -> Table:
    header = [
        "tyre set",
        "type",
        "C_xr (20 °C)",
        "C_x",
        "μ_max by surface",
        "windows (ABS)",
        "truth",
    ]
    rows = []
    for t in report.tyres:
        s = t.summary
        mus = "; ".join(f"{k}: {post(v, 2)}" for k, v in s["mu_max"].items())
        truth = "–"
        if t.truth:
            truth = ", ".join(f"{k} {fmt(v)}" for k, v in t.truth.items())
        rows.append(
            [
                t.name,
                t.tyre_type or "unknown",
                post(s["c_xr"]),
                post(s["c_x"]),
                mus,
                f"{s['n_windows']} ({s['n_abs_windows']})",
                truth,
            ]
        )
    return header, rows


def fleet_table(report: Report) -> Table:
    f = report.fleet
    header = ["tyre type", "μ at reference C_xr (a)", "slope per 100/C_xr (b)", "residual sd"]
    rows = [[t, post(p["a"]), post(p["b"]), post(p["sigma"])] for t, p in f.parameters.items()]
    rows.append(
        [
            "OLS (thesis, all types)",
            f"intercept {fmt(f.ols['intercept'])}",
            f"slope {fmt(f.ols['slope'])} per 1/C_xr",
            f"{fmt(f.ols['resid_sd'])} (R² {fmt(f.ols['r2'], 2)})",
        ]
    )
    return header, rows


#: How the V_max table names the sources of a set's lateral parameters.
_CORNERING_FROM = {"measured": "measured c_y front/rear", "type_prior": "k_type · C_xr"}
_MU_Y_FROM = {
    "measured": "measured μ_y",
    "mu_max": "μ_max (μ_y not observed)",
    "surface_prior": "surface prior (μ_y not observed)",
    "type_prior": "0.95 μ_type",
}


def vmax_table(report: Report) -> Table:
    header = [
        "tyre set",
        "type",
        "C_xr",
        "lateral parameters",
        "predicted V_max [km/h]",
        "measured [km/h]",
    ]
    rows = []
    for r in report.vmax.rows:
        meas = (
            f"[{fmt(r['measured_lo'])}, {fmt(r['measured_hi'])})"
            if math.isfinite(r["measured_lo"])
            else "–"
        )
        cornering = _CORNERING_FROM[r.get("lateral_source", "type_prior")]
        mu_y = _MU_Y_FROM[r.get("mu_y_source", "type_prior")]
        rows.append(
            [
                r["tyre"],
                r["tyre_type"] or "–",
                fmt(r["c_xr"]),
                f"{cornering}; {mu_y}",
                post(r["summary"]) + _beyond_range(r),
                meas,
            ]
        )
    return header, rows


def _beyond_range(row: dict) -> str:
    """What a V_max row's draws beyond the search range mean for its interval ("" if none):
    they count at the range's end, so an interval ending there means "or beyond"."""
    n = f" of {len(row['draws'])}" if "draws" in row else ""
    notes = []
    if row.get("below_range"):
        notes.append(f"{row['below_range']}{n} draws fail at the lowest speed searched")
    if row.get("above_range"):
        notes.append(f"{row['above_range']}{n} draws pass at the highest speed searched")
    return f" ({'; '.join(notes)}: counted there)" if notes else ""


def vmax_comparison_table(report: Report) -> Table:
    c = report.vmax.comparison
    header = ["model", "ELPD (measured Table 6.2)", "SE", "notes"]
    rows = []
    if "driver_free" in c:
        rows.append(
            [
                "driver-free simulation",
                fmt(c["driver_free"]["elpd"]),
                fmt(c["driver_free"]["se"]),
                f"slope predicted {fmt(c['predicted_slope_kmh_per_cxr'])} vs measured "
                f"{fmt(c['measured_slope_kmh_per_cxr'])} km/h per unit C_xr",
            ]
        )
    if "extended" in c:
        e = c["extended"]
        rows.append(
            [
                "extended (driver offset, adaptation, noise)",
                fmt(e["elpd_loo"]),
                fmt(e["se"]),
                f"offset {post(e['delta_kmh'])} km/h; gain {fmt(c['elpd_gain']['diff'])} ± "
                f"{fmt(c['elpd_gain']['se'])}; Pareto k max {fmt(e['pareto_k_max'], 2)}",
            ]
        )
    return header, rows


def wear_table(report: Report) -> Table:
    w = report.wear
    header = ["quantity", "value"]
    rows = []
    for t, k in w.kappa.items():
        rows.append([f"κ {t} (extended) [1/K]", f"{post(k, 2)} (true {fmt(k['true'])})"])
    for m in ("baseline", "extended"):
        if m in w.comparison:
            c = w.comparison[m]
            rows.append(
                [
                    f"PSIS-LOO ELPD {m}",
                    f"{fmt(c['elpd_loo'], 5)} ± {fmt(c['se'])} "
                    f"(Pareto k max {fmt(c['pareto_k_max'], 2)})",
                ]
            )
    g = w.comparison.get("elpd_gain_extended")
    if g:
        rows.append(["ELPD gain extended − baseline", f"{fmt(g['diff'])} ± {fmt(g['se'])}"])
    for name in next(iter(w.curves.values())):
        for m in w.curves:
            cc = w.curves[m][name]
            rows.append(
                [
                    f"{name}: wear at {fmt(cc['ambient_c'][-1])} °C / at "
                    f"{fmt(w.reference_c)} °C ({m})",
                    f"{fmt(cc['q50'][-1])} [{fmt(cc['q05'][-1])}, {fmt(cc['q95'][-1])}]"
                    f" (truth {fmt(cc['truth'][-1])})",
                ]
            )
    rel = w.thesis["relative_wear_difference"]
    rows.append(
        [
            "thesis Table 6.1 reproduction: |I_40 − I_7| / max",
            f"soft {fmt(rel['soft'])}, stiff {fmt(rel['stiff'])}; soft wears relatively "
            f"more in heat: {fmt(w.thesis['soft_wears_relatively_more_in_heat'])}",
        ]
    )
    return header, rows


def warnings_table(report: Report) -> Table:
    header = [
        "subject",
        "type",
        "predicted",
        "90 % interval",
        "event",
        "P(event)",
        "threshold",
        "verdict",
    ]
    rows = []
    for w in report.warnings:
        lo, hi = w["interval_90"]
        rows.append(
            [
                w["subject"],
                w.get("tyre_type", ""),
                f"{w['quantity']} {fmt(w['predicted']['mean'])}",
                f"[{fmt(lo)}, {fmt(hi)}]",
                w["event"],
                fmt(w["probability"]),
                fmt(w["threshold"]),
                w["verdict"],
            ]
        )
    return header, rows


def diagnostics_table(report: Report) -> Table:
    header = [
        "fit",
        "method",
        "chains",
        "R-hat max",
        "ESS min",
        "divergences",
        "converged",
        "adequate",
        "note",
    ]
    rows = []
    for d in report.diagnostics:
        notes = [d.get("reason", "") or ""] + list(d.get("adequacy_reasons", ()))
        rows.append(
            [
                d["fit"],
                d.get("method", "–"),
                fmt(d.get("chains")),
                fmt(d.get("r_hat_max")),
                fmt(d.get("ess_min"), 4),
                fmt(d.get("divergences")),
                fmt(bool(d.get("converged"))),
                fmt(bool(d.get("adequate", True))) if d.get("adequate", True) else "NO",
                "; ".join(n for n in notes if n),
            ]
        )
    return header, rows


def criticism_table(entry: dict, top: int = 6) -> Table:
    header = ["candidate", "BH q", "ELPD gain", "SE", "effect [90 % HDI]", "found"]
    rows = []
    for c in entry["candidates"][:top]:
        e = c["effect"]
        rows.append(
            [
                c["covariate"],
                fmt(c["q_value"], 2),
                fmt(c["elpd_gain"]),
                fmt(c["se"]),
                post(e) if e and "hdi_90" in e else "–",
                fmt(c["found"]),
            ]
        )
    return header, rows


def timing_table(report: Report) -> Table:
    header = ["step", "wall-clock [s]", "CPU [s]"]
    return header, [
        [k, f"{v['wall_s']:.1f}", f"{v['cpu_s']:.1f}"] for k, v in report.timings.items()
    ]
