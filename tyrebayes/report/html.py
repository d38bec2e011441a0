"""The report as one self-contained HTML page (figures embedded as base64 PNG, inline CSS)."""

from __future__ import annotations

import base64
import html

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

_CSS = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;
padding:0 1em;color:#222;line-height:1.45}
h1{font-size:1.7em;margin-bottom:.1em}
h2{border-bottom:1px solid #ddd;padding-bottom:.2em;margin-top:1.8em}
.sub{color:#666;margin-top:0}table{border-collapse:collapse;margin:.8em 0;font-size:.86em}
th,td{border:1px solid #ddd;padding:.3em .55em;text-align:left;vertical-align:top}
th{background:#f4f4f4}tr:nth-child(even) td{background:#fafafa}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #eee}
figcaption{color:#555;font-size:.88em}.warn{color:#b00;font-weight:600}.ok{color:#070}
.insufficient_evidence{color:#b60}ul.head li{margin:.2em 0}code{background:#f4f4f4;padding:0 .2em}
"""


def _table(t: Table) -> str:
    header, rows = t
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = []
    for r in rows:
        cells = []
        for c in r:
            cls = f' class="{c}"' if c in ("warn", "ok", "insufficient_evidence") else ""
            cells.append(f"<td{cls}>{html.escape(str(c))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _figure(name: str, png: bytes, caption: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return (
        f'<figure id="fig-{name}"><img alt="{html.escape(caption)}" '
        f'src="data:image/png;base64,{data}"><figcaption>{html.escape(caption)} '
        f'(<a href="figures/{name}.png">PNG</a>)</figcaption></figure>'
    )


def _p(text: str) -> str:
    return f"<p>{html.escape(text)}</p>"


def render_html(report: Report, figures: dict) -> str:
    """HTML text of ``report``; ``figures`` maps name -> (PNG bytes, caption)."""
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{html.escape(report.title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(report.title)}</h1><p class='sub'>{html.escape(report.subtitle)}</p>",
        "<h2>Summary</h2><ul class='head'>",
        *[f"<li>{html.escape(h)}</li>" for h in headline(report)],
        "</ul>",
    ]

    def fig(name):
        if name in figures:
            png, caption = figures[name]
            parts.append(_figure(name, png, caption))

    if report.tyres:
        parts += ["<h2>Per-tyre posteriors: force against slip</h2>", _p(SECTION_TEXT["tyres"])]
        fig("tyre_curves")
        parts.append(_table(tyre_table(report)))
    if report.laterals:
        parts += ["<h2>Cornering: axle force against slip angle</h2>", _p(LATERAL_TEXT)]
        fig("lateral_curves")
        parts.append(_table(lateral_table(report)))
    if report.fleet is not None:
        parts += ["<h2>Friction against 1/C_xr by tyre type</h2>", _p(SECTION_TEXT["fleet"])]
        fig("friction_vs_inverse_stiffness")
        parts.append(_table(fleet_table(report)))
    if report.vmax is not None:
        parts += ["<h2>Critical lane-change speed V_max</h2>", _p(SECTION_TEXT["vmax"])]
        fig("vmax")
        parts.append(_table(vmax_table(report)))
        if report.vmax.comparison:
            parts.append(_table(vmax_comparison_table(report)))
    if report.wear is not None:
        parts += ["<h2>Relative wear against temperature</h2>", _p(SECTION_TEXT["wear"])]
        fig("wear_vs_temperature")
        parts.append(_table(wear_table(report)))
    if report.warnings:
        parts += ["<h2>Warnings</h2>", _p(SECTION_TEXT["warnings"])]
        fig("warnings")
        parts.append(_table(warnings_table(report)))
    if report.diagnostics:
        parts += ["<h2>Diagnostics</h2>", _p(SECTION_TEXT["diagnostics"])]
        parts.append(_table(diagnostics_table(report)))
    if report.criticism:
        parts += ["<h2>Model criticism</h2>", _p(SECTION_TEXT["criticism"])]
        for entry in report.criticism:
            b = entry["baseline"]
            found = ", ".join(entry["found"]) or "nothing"
            parts.append(f"<h3>{html.escape(entry['title'])}</h3>")
            parts.append(_p(f"Baseline ELPD {b['elpd']:.2f} (SE {b['se']:.2f}). Found: {found}."))
            parts.append(_table(criticism_table(entry)))
    if report.timings or report.notes:
        parts.append("<h2>Run</h2>")
        if report.timings:
            parts.append(_table(timing_table(report)))
        parts += [_p(n) for n in report.notes]
    parts.append("</body></html>")
    return "\n".join(parts)
