"""The report's words: what each section shows (no numbers) and the headline (numbers from data)."""

from __future__ import annotations

from .content import Report

SECTION_TEXT = {
    "tyres": (
        "Each panel is one tyre set: 0.25 s windows of measured slip and normalised force of the "
        "driven axle (per-drive slip and force offsets removed at their posterior means), and the "
        "tyre curve of the posterior (brush family, median and 90 % band) per road surface. The "
        "slope at zero is C_x at the drives' tyre temperature; C_xr is the same stiffness "
        "compensated to 20 °C. ABS windows (if any) inform μ_max through their force level and "
        "are not drawn."
    ),
    "fleet": (
        "The thesis fitted one least-squares line of friction potential against 1/C_xr over all "
        "tyre types and reported its R². Here each point is a tyre set (horizontal bars: ±1 sd of "
        "its stiffness); the coloured bands are the hierarchical model's 90 % posterior "
        "predictive intervals for a new set of each type (slopes partially pooled across types, "
        "stiffness measurement error included), the dashed line the thesis' OLS line with its "
        "90 % prediction interval."
    ),
    "vmax": (
        "Predictive distribution of the critical ISO 3888-2 double-lane-change speed from "
        "closed-loop simulation (single-track model, lateral brush tyres, preview driver). "
        "Where a tyre fit carries a lateral posterior, the simulation runs on its measured "
        "cornering stiffness per axle and μ_y (μ_max, or the surface's prior, where the drive "
        "did not near the lateral peak); otherwise cornering stiffness and lateral friction are "
        "drawn from the type-level relations (C_y = k_type · C_xr, μ_y = 0.95 μ_type). The "
        "table says which each set used. Hatched boxes: the thesis' Table 6.2 measurements (the "
        "driver passed at the lower edge and failed 10 km/h higher)."
    ),
    "wear": (
        "Wear rate of the same tyre and driving at each ambient temperature relative to the "
        "reference temperature, per posterior draw. Baseline: the thesis' Schallamach model "
        "(abrasability independent of temperature; only C_x(T) changes with heat). Extended: "
        "abrasability γ(T) = γ_20 exp(κ (T − 20 °C)) with κ per tyre type, fitted to tread-depth "
        "readings and radius drift of a simulated year of driving."
    ),
    "warnings": (
        "Winter suitability of each tyre set: predictive snow friction from the fleet model at "
        "the set's posterior stiffness; a warning is issued when P(μ < μ_min) exceeds the cost "
        "threshold, and withheld ('insufficient_evidence') when the predictive interval "
        "straddles μ_min too widely to tell."
    ),
    "diagnostics": (
        "Convergence evidence of every fit in this report, judged by one policy: NUTS needs "
        "rank-normalised split R-hat ≤ 1.02, bulk and tail ESS ≥ 100 per chain and at most one "
        "divergent transition per thousand draws; the MAP + Laplace and SVI paths have no R-hat, "
        "report their draw count as ESS and need a successful optimiser. 'adequate' is the "
        "model's own posterior predictive check of its data; an inadequate fit is marked NO."
    ),
    "criticism": (
        "What the models do not know: every candidate covariate is scanned against the "
        "baseline's residuals with a permutation test (Benjamini-Hochberg q-value, false-discovery "
        "rate 5 %) and is a finding only if the extended model also predicts better (PSIS-LOO "
        "ELPD gain > 0)."
    ),
}


def headline(report: Report) -> list[str]:
    """Headline sentences computed from the report's numbers."""
    out = []
    if report.tyres:
        conv = sum(bool(t.diagnostics.get("converged", False)) for t in report.tyres)
        out.append(f"{len(report.tyres)} per-tyre posteriors ({conv} converged).")
        # Real data has no truth to compare with: say what the fit gives and what it assumes.
        for t in report.tyres:
            if t.truth is None and t.source:
                c = t.summary["c_x"]
                lo, hi = c["hdi_90"]
                out.append(
                    f"{t.name}: C_x {c['mean']:.1f} ± {c['sd']:.1f} (90 % {lo:.1f}–{hi:.1f}); "
                    f"{t.source}."
                )
    f = report.fleet
    if f is not None:
        types = ", ".join(f"{t} {p['b']['mean']:+.3f}" for t, p in f.parameters.items())
        out.append(
            f"Friction on {f.surface} vs 1/C_xr over {f.n_sets} sets: thesis OLS R² = "
            f"{f.ols['r2']:.2f}; hierarchical slopes per 100/C_xr by type: {types}."
        )
    v = report.vmax
    if v is not None and v.comparison.get("driver_free"):
        c = v.comparison
        txt = (
            f"V_max: predicted slope {c['predicted_slope_kmh_per_cxr']:+.2f} vs measured "
            f"{c['measured_slope_kmh_per_cxr']:+.2f} km/h per unit C_xr"
        )
        if "elpd_gain" in c:
            g = c["elpd_gain"]
            txt += (
                f"; a driver-offset model gains {g['diff']:.1f} ± {g['se']:.1f} ELPD over the "
                "driver-free simulation"
            )
        out.append(txt + ".")
    w = report.wear
    if w is not None:
        g = w.comparison.get("elpd_gain_extended", {})
        k = "; ".join(f"κ {t} {s['mean']:.3f}/K" for t, s in w.kappa.items())
        out.append(
            f"Wear: extended model (temperature-dependent abrasability) gains "
            f"{g.get('diff', float('nan')):.1f} ± {g.get('se', float('nan')):.1f} ELPD; {k}."
        )
    if report.warnings:
        n_warn = sum(x["verdict"] == "warn" for x in report.warnings)
        names = ", ".join(x["subject"] for x in report.warnings if x["verdict"] == "warn")
        out.append(
            f"Warnings: {n_warn} of {len(report.warnings)} sets"
            + (f" ({names})." if names else ".")
        )
    for c in report.criticism:
        out.append(f"Criticism of {c['title']}: found {', '.join(c['found']) or 'nothing'}.")
    if report.diagnostics:
        bad = [d["fit"] for d in report.diagnostics if not d.get("converged")]
        out.append(
            f"Diagnostics: {len(report.diagnostics) - len(bad)} of {len(report.diagnostics)} "
            "fits converged" + (f" (not: {', '.join(bad)})." if bad else ".")
        )
        inadequate = [d["fit"] for d in report.diagnostics if not d.get("adequate", True)]
        if inadequate:
            out.append(
                f"Model inadequate (the posterior predictive misses the data): "
                f"{', '.join(inadequate)}."
            )
    return out
