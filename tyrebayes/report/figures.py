"""The report's figures as PNG bytes (matplotlib, Agg backend): they draw, they never compute.

Each function takes a section of :mod:`tyrebayes.report.content` and returns PNG bytes.
"""

from __future__ import annotations

import io

import numpy as np

SURFACE_COLOURS = {"dry": "#8c564b", "wet": "#1f77b4", "snow": "#17becf", "ice": "#9467bd"}
TYPE_COLOURS = {"winter": "#1f77b4", "all_season": "#2ca02c", "summer": "#d62728"}
TYPE_LABELS = {"winter": "winter", "all_season": "all-season", "summer": "summer"}
DPI = 110


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight")
    _plt().close(fig)
    return buf.getvalue()


def tyre_curves(tyres) -> bytes:
    """Force–slip windows with the posterior median curve and 90 % band per tyre and surface."""
    plt = _plt()
    n = len(tyres)
    cols = min(3, n)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.3 * cols, 3.5 * rows), squeeze=False)
    for ax, t in zip(axes.ravel(), tyres, strict=False):
        use = ~t.at_limit
        for i, s in enumerate(t.surfaces):
            colour = SURFACE_COLOURS.get(s, "k")
            sel = use & (t.window_surface == i)
            ax.plot(t.slip[sel], t.rho[sel], ".", ms=2.5, alpha=0.35, color=colour)
            grid, lo, mid, hi = t.curve[s]
            ax.fill_between(grid, lo, hi, color=colour, alpha=0.25, lw=0)
            ax.plot(grid, mid, color=colour, lw=1.6, label=s)
        c = t.summary["c_xr"]
        title = f"{t.name}\nC_xr {c['mean']:.1f} ± {c['sd']:.1f}"
        if t.truth and "c_xr" in t.truth:
            title += f" (true {t.truth['c_xr']:.1f})"
        ax.set_title(title, fontsize=9)
        ax.axhline(0.0, color="0.8", lw=0.6, zorder=0)
        ax.axvline(0.0, color="0.8", lw=0.6, zorder=0)
        ax.set_xlabel("slip σ_x (offset removed) [-]", fontsize=8)
        ax.set_ylabel("ρ_x = F_x / F_z [-]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7, loc="upper left")
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    fig.suptitle("Force–slip windows and posterior curve (median, 90 % band)", fontsize=11)
    fig.tight_layout()
    return _png(fig)


def lateral_curves(laterals) -> bytes:
    """Each axle's ρ_y against its slip angle, with the posterior median curve and 90 % band."""
    plt = _plt()
    n = len(laterals)
    fig, axes = plt.subplots(n, 2, figsize=(8.6, 3.5 * n), squeeze=False)
    for row, lat in zip(axes, laterals, strict=True):
        for ax, axle, colour in zip(row, ("front", "rear"), ("tab:blue", "tab:red"), strict=True):
            ax.plot(lat.alpha[axle], lat.rho[axle], ".", ms=2.0, alpha=0.3, color=colour)
            grid, lo, mid, hi = lat.curve[axle]
            ax.fill_between(grid, lo, hi, color=colour, alpha=0.25, lw=0)
            ax.plot(grid, mid, color=colour, lw=1.6)
            c = lat.summary[f"c_y_{axle}"]
            ax.set_title(
                f"{lat.name}, {axle}: c_y {c['mean']:.1f} ± {c['sd']:.1f} /rad", fontsize=9
            )
            ax.axhline(0.0, color="0.8", lw=0.6, zorder=0)
            ax.axvline(0.0, color="0.8", lw=0.6, zorder=0)
            ax.set_xlabel(f"{axle} slip angle α [rad] (steering equation)", fontsize=8)
            ax.set_ylabel("ρ_y = F_y / F_z,static [-]", fontsize=8)
            ax.tick_params(labelsize=7)
    fig.suptitle("Cornering: axle force against slip angle (median, 90 % band)", fontsize=11)
    fig.tight_layout()
    return _png(fig)


def friction_vs_inverse_stiffness(fleet) -> bytes:
    """Thesis Fig. 6.2 done right: μ vs 100/C_xr by type, hierarchical bands, OLS line and R²."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    for t, (grid, lo, mid, hi) in fleet.bands.items():
        colour = TYPE_COLOURS.get(t, "k")
        x = 100.0 / grid
        ax.fill_between(x, lo, hi, color=colour, alpha=0.18, lw=0)
        ax.plot(
            x,
            mid,
            color=colour,
            lw=1.8,
            label=f"{TYPE_LABELS.get(t, t)}: hierarchical, 90 % predictive",
        )
        sel = fleet.tyre_type == t
        xerr = 100.0 * fleet.c_xr_sd[sel] / fleet.c_xr[sel] ** 2
        ax.errorbar(
            100.0 / fleet.c_xr[sel],
            fleet.mu[sel],
            xerr=xerr,
            fmt="o",
            ms=4,
            color=colour,
            ecolor=colour,
            elinewidth=0.8,
            alpha=0.85,
        )
    grid, lo, mid, hi = fleet.ols["band"]
    x = 100.0 / grid
    ax.plot(x, mid, "k--", lw=1.4, label=f"OLS line (thesis), R² = {fleet.ols['r2']:.2f}")
    ax.plot(x, lo, "k:", lw=0.9, label="OLS 90 % prediction interval")
    ax.plot(x, hi, "k:", lw=0.9)
    ax.set_xlabel("100 / C_xr [-]")
    ax.set_ylabel(f"friction potential {fleet.outcome} on {fleet.surface} [-]")
    ax.set_title(f"Friction against inverse stiffness ({fleet.n_sets} sets, {fleet.surface})")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return _png(fig)


def vmax_distributions(vmax) -> bytes:
    """Predictive V_max per set (violins) beside the measured interval [pass, pass + 10) km/h."""
    plt = _plt()
    rows = vmax.rows
    fig, ax = plt.subplots(figsize=(8.0, 0.55 * len(rows) + 1.6))
    y = np.arange(len(rows))[::-1]
    data = [r["draws"][np.isfinite(r["draws"])] for r in rows]
    parts = ax.violinplot(data, positions=y, vert=False, widths=0.8, showextrema=False)
    for body, r in zip(parts["bodies"], rows, strict=True):
        body.set_facecolor(TYPE_COLOURS.get(r["tyre_type"], "0.5"))
        body.set_alpha(0.45)
    for yi, r in zip(y, rows, strict=True):
        s = r["summary"]
        ax.plot(s["hdi_90"], [yi, yi], color="k", lw=1.2)
        ax.plot([s["mean"]], [yi], "k|", ms=10)
        if np.isfinite(r["measured_lo"]):
            ax.add_patch(
                plt.Rectangle(
                    (r["measured_lo"], yi - 0.35),
                    r["measured_hi"] - r["measured_lo"],
                    0.7,
                    fill=False,
                    hatch="///",
                    edgecolor="darkorange",
                    lw=1.2,
                )
            )
    ax.plot([], [], color="k", lw=1.2, label="predictive mean and 90 % HDI")
    if any(np.isfinite(r["measured_lo"]) for r in rows):
        ax.add_patch(
            plt.Rectangle(
                (0, 0),
                0,
                0,
                fill=False,
                hatch="///",
                edgecolor="darkorange",
                label="measured (Table 6.2): passed, next step failed",
            )
        )
    ax.set_yticks(y)
    labels = [
        f"{r['tyre']} (c_y measured)"
        if r.get("lateral_source") == "measured"
        else f"{r['tyre']} (C_xr {r['c_xr']:.0f})"
        for r in rows
    ]
    ax.set_yticklabels(labels, fontsize=8)
    ax.set_xlabel("critical lane-change speed V_max [km/h]")
    ax.set_title(f"ISO 3888-2 V_max: predictive vs measured ({vmax.vehicle})")
    ax.grid(axis="x", alpha=0.3)
    height = fig.get_figheight()
    fig.legend(fontsize=8, loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0.0, 0.45 / height, 1.0, 1.0))
    return _png(fig)


def wear_vs_temperature(wear) -> bytes:
    """Relative wear rate vs ambient for the soft and the stiff tyre, baseline vs extended."""
    plt = _plt()
    tyres = list(next(iter(wear.curves.values())))
    fig, axes = plt.subplots(1, len(tyres), figsize=(5.2 * len(tyres), 4.0), squeeze=False)
    styles = {"baseline": ("0.35", "--"), "extended": ("tab:red", "-")}
    for ax, name in zip(axes[0], tyres, strict=True):
        for model, per_tyre in wear.curves.items():
            c = per_tyre[name]
            colour, ls = styles.get(model, ("k", "-"))
            ax.fill_between(c["ambient_c"], c["q05"], c["q95"], color=colour, alpha=0.2, lw=0)
            ax.plot(
                c["ambient_c"],
                c["q50"],
                ls,
                color=colour,
                lw=1.8,
                label=f"{model} (κ {'fitted' if model == 'extended' else '= 0'})",
            )
            if "truth" in c:
                ax.plot(
                    c["ambient_c"],
                    c["truth"],
                    "o",
                    color="k",
                    ms=3,
                    label="simulated truth" if model == "extended" else None,
                )
        c = next(iter(wear.curves.values()))[name]
        ax.axhline(1.0, color="0.8", lw=0.8, zorder=0)
        ax.set_title(f"{name} tyre (C_xr {c['c_xr']:.0f}, {TYPE_LABELS.get(c['tyre_type'], '')})")
        ax.set_xlabel("ambient temperature [°C]")
        ax.set_ylabel(f"wear rate / wear rate at {wear.reference_c:g} °C")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Relative tread wear vs temperature (median, 90 % band)", fontsize=11)
    fig.tight_layout()
    return _png(fig)


def warning_probabilities(warnings) -> bytes:
    """P(event) per warning against its decision threshold."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 0.45 * len(warnings) + 1.4))
    y = np.arange(len(warnings))[::-1]
    colours = {"warn": "tab:red", "ok": "tab:green", "insufficient_evidence": "tab:orange"}
    p = [w["probability"] for w in warnings]
    ax.barh(y, p, color=[colours.get(w["verdict"], "0.5") for w in warnings], alpha=0.8)
    for yi, w in zip(y, warnings, strict=True):
        ax.plot([w["threshold"]] * 2, [yi - 0.4, yi + 0.4], "k-", lw=1.5)
        ax.text(min(w["probability"], 0.97) + 0.01, yi, w["verdict"], va="center", fontsize=7)
    ax.set_yticks(y)
    ax.set_yticklabels([f"{w['subject']}: {w['event']}" for w in warnings], fontsize=7)
    ax.set_xlim(0, 1.1)
    ax.set_xlabel("posterior predictive probability (black tick: decision threshold)")
    ax.set_title("Warnings")
    fig.tight_layout()
    return _png(fig)
