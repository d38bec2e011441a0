"""Write a report into a folder: ``report.html``, ``report.md``, ``report.json``, ``figures/*.png``.

Every file is written atomically (temporary name, then rename), figures first, so a reader never
sees a page whose figures are missing.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from .._io import atomic_write_bytes
from .._io import to_jsonable as _to_jsonable
from . import figures as F
from .content import Report
from .html import render_html
from .markdown import render_markdown


def render_figures(report: Report) -> dict:
    """name -> (PNG bytes, caption) for every section the report has."""
    out = {}
    if report.tyres:
        out["tyre_curves"] = (
            F.tyre_curves(report.tyres),
            "Force–slip windows and posterior brush curve (median, 90 % band) per tyre set",
        )
    if report.laterals:
        out["lateral_curves"] = (
            F.lateral_curves(report.laterals),
            "Cornering: each axle's lateral force over its static load against its slip angle "
            "(the steering equation's), posterior median curve and 90 % band",
        )
    if report.fleet is not None:
        out["friction_vs_inverse_stiffness"] = (
            F.friction_vs_inverse_stiffness(report.fleet),
            "Friction potential against 100/C_xr: hierarchical predictive bands by type and the "
            "thesis' OLS line",
        )
    if report.vmax is not None:
        out["vmax"] = (
            F.vmax_distributions(report.vmax),
            "Predictive V_max per tyre set beside the measured Table 6.2 intervals",
        )
    if report.wear is not None:
        out["wear_vs_temperature"] = (
            F.wear_vs_temperature(report.wear),
            "Wear rate relative to the reference temperature: baseline vs extended model",
        )
    if report.warnings:
        out["warnings"] = (
            F.warning_probabilities(report.warnings),
            "Probability of each warning's event against its decision threshold",
        )
    return out


def summary_json(report: Report) -> dict:
    """The machine-readable summary (also ``report.json``): every number the report states."""
    out: dict = {"title": report.title, "subtitle": report.subtitle}
    out["tyres"] = [
        {
            "name": t.name,
            "tyre_type": t.tyre_type,
            "summary": t.summary,
            "diagnostics": t.diagnostics,
            "truth": t.truth,
            "source": t.source,
        }
        for t in report.tyres
    ]
    out["laterals"] = [{"name": lat.name, "summary": lat.summary} for lat in report.laterals]
    if report.fleet is not None:
        f = report.fleet
        out["fleet"] = {
            "surface": f.surface,
            "n_sets": f.n_sets,
            "parameters": f.parameters,
            "diagnostics": f.diagnostics,
            "ols": {k: v for k, v in f.ols.items() if k != "band"},
        }
    if report.vmax is not None:
        out["vmax"] = {
            "vehicle": report.vmax.vehicle,
            "sets": [{k: v for k, v in r.items() if k != "draws"} for r in report.vmax.rows],
            "comparison": report.vmax.comparison,
        }
    if report.wear is not None:
        w = report.wear
        out["wear"] = {
            "reference_c": w.reference_c,
            "kappa": w.kappa,
            "comparison": w.comparison,
            "diagnostics": w.diagnostics,
            "thesis": w.thesis,
            "curves": w.curves,
        }
    out["warnings"] = report.warnings
    out["diagnostics"] = report.diagnostics
    out["criticism"] = [{k: v for k, v in c.items() if k != "ppc"} for c in report.criticism]
    out["timings_s"] = report.timings
    return _to_jsonable(out)


def _write(path: Path, data: bytes) -> None:
    atomic_write_bytes(path, data)
    path.chmod(0o644)  # a report is for sharing (the temporary file was private)


@dataclass(frozen=True)
class ReportFiles:
    """The files :func:`write_report` wrote.

    Attributes
    ----------
    html, markdown, json : Path
        ``report.html``, ``report.md`` and ``report.json``.
    figures : tuple of (str, Path)
        Each figure's name and PNG (``figures/NAME.png``), in the report's order.

    Examples
    --------
    >>> files = ReportFiles(Path("r.html"), Path("r.md"), Path("r.json"), (("x", Path("x.png")),))
    >>> list(files.to_dict())
    ['figure:x', 'report.html', 'report.md', 'report.json']
    """

    html: Path
    markdown: Path
    json: Path
    figures: tuple[tuple[str, Path], ...]

    def to_dict(self) -> dict[str, Path]:
        """The paths by name: ``figure:NAME`` for each figure, then the three report files."""
        return {
            **{f"figure:{name}": path for name, path in self.figures},
            "report.html": self.html,
            "report.md": self.markdown,
            "report.json": self.json,
        }


def write_report(report: Report, out_dir: str | Path) -> ReportFiles:
    """Render and write the report into ``out_dir``: figures first, then the pages.

    Parameters
    ----------
    report : Report
        What to show (:class:`~tyrebayes.report.content.Report`).
    out_dir : str or Path
        Folder to write into (made if missing); files there of the same names are replaced.

    Returns
    -------
    ReportFiles
        The paths written.

    Examples
    --------
    >>> import tempfile
    >>> from tyrebayes.report.content import Report
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     files = write_report(Report(title="empty", subtitle=""), folder)
    ...     print(files.html.name, files.figures)
    report.html ()
    """
    out_dir = Path(out_dir)
    figs = render_figures(report)
    figures = []
    for name, (png, _caption) in figs.items():
        p = out_dir / "figures" / f"{name}.png"
        _write(p, png)
        figures.append((name, p))
    for name, text in (
        ("report.html", render_html(report, figs)),
        ("report.md", render_markdown(report, figs)),
        ("report.json", json.dumps(summary_json(report), indent=2) + "\n"),
    ):
        _write(out_dir / name, text.encode("utf-8"))
    return ReportFiles(
        html=out_dir / "report.html",
        markdown=out_dir / "report.md",
        json=out_dir / "report.json",
        figures=tuple(figures),
    )
