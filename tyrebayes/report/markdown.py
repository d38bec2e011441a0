"""The report as Markdown, figures linked as ``figures/NAME.png`` beside it."""

from __future__ import annotations

from .content import Report
from .lateral import LATERAL_TEXT, lateral_table
from .sections_text import SECTION_TEXT, headline
from .tables import (
    Table,
    criticism_table,
    diagnostics_table,
    fleet_table,
    timing_table,
    tyre_table,
    vmax_comparison_table,
    vmax_table,
    warnings_table,
    wear_table,
)


def _cell(x) -> str:
    return str(x).replace("|", "\\|").replace("\n", " ")


def _table(t: Table) -> str:
    header, rows = t
    lines = [
        "| " + " | ".join(_cell(h) for h in header) + " |",
        "|" + "|".join("---" for _ in header) + "|",
    ]
    lines += ["| " + " | ".join(_cell(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def render_markdown(report: Report, figures: dict) -> str:
    """Markdown text of ``report``; ``figures`` maps name -> (PNG bytes, caption)."""
    out = [f"# {report.title}", "", f"*{report.subtitle}*", "", "## Summary", ""]
    out += [f"- {h}" for h in headline(report)] + [""]

    def fig(name):
        if name in figures:
            out.extend([f"![{figures[name][1]}](figures/{name}.png)", ""])

    def section(title, key, figure, tables):
        out.extend([f"## {title}", "", SECTION_TEXT[key], ""])
        if figure:
            fig(figure)
        for t in tables:
            out.extend([_table(t), ""])

    if report.tyres:
        section(
            "Per-tyre posteriors: force against slip", "tyres", "tyre_curves", [tyre_table(report)]
        )
    if report.laterals:
        out.extend(["## Cornering: axle force against slip angle", "", LATERAL_TEXT, ""])
        fig("lateral_curves")
        out.extend([_table(lateral_table(report)), ""])
    if report.fleet is not None:
        section(
            "Friction against 1/C_xr by tyre type",
            "fleet",
            "friction_vs_inverse_stiffness",
            [fleet_table(report)],
        )
    if report.vmax is not None:
        tables = [vmax_table(report)]
        if report.vmax.comparison:
            tables.append(vmax_comparison_table(report))
        section("Critical lane-change speed V_max", "vmax", "vmax", tables)
    if report.wear is not None:
        section(
            "Relative wear against temperature", "wear", "wear_vs_temperature", [wear_table(report)]
        )
    if report.warnings:
        section("Warnings", "warnings", "warnings", [warnings_table(report)])
    if report.diagnostics:
        section("Diagnostics", "diagnostics", None, [diagnostics_table(report)])
    if report.criticism:
        out.extend(["## Model criticism", "", SECTION_TEXT["criticism"], ""])
        for entry in report.criticism:
            b = entry["baseline"]
            found = ", ".join(entry["found"]) or "nothing"
            out.extend(
                [
                    f"### {entry['title']}",
                    "",
                    f"Baseline ELPD {b['elpd']:.2f} (SE {b['se']:.2f}). Found: {found}.",
                    "",
                    _table(criticism_table(entry)),
                    "",
                ]
            )
    if report.timings or report.notes:
        out.extend(["## Run", ""])
        if report.timings:
            out.extend([_table(timing_table(report)), ""])
        out.extend([n + "\n" for n in report.notes])
    return "\n".join(out) + "\n"
