"""The report writers on a hand-made report: files, links, numbers, atomic replacement."""

from __future__ import annotations

import json
import re

import numpy as np

from tyrebayes.report import Report, write_report
from tyrebayes.report.content import FleetSection, TyreSection, VmaxSection, WearSection
from tyrebayes.report.sections_text import headline
from tyrebayes.report.tables import diagnostics_table, fmt, post


def _summary(mean: float, sd: float) -> dict:
    return {"mean": mean, "sd": sd, "hdi_90": [mean - 1.645 * sd, mean + 1.645 * sd]}


def _report() -> Report:
    rng = np.random.default_rng(0)
    slip = rng.uniform(-0.002, 0.006, 200)
    grid = np.linspace(-0.003, 0.007, 20)
    tyre = TyreSection(
        name="set A",
        tyre_type="winter",
        surfaces=("dry",),
        slip=slip,
        rho=30.0 * slip + rng.normal(0, 0.01, 200),
        window_surface=np.zeros(200, int),
        at_limit=np.zeros(200, bool),
        curve={"dry": (grid, 28 * grid, 30 * grid, 32 * grid)},
        summary={
            "c_x": _summary(30.0, 1.0),
            "c_xr": _summary(31.0, 1.2),
            "mu_max": {"dry": _summary(0.9, 0.2)},
            "n_windows": 200,
            "n_abs_windows": 0,
        },
        diagnostics={"method": "fast", "chains": 1, "converged": True},
        truth={"c_xr": 30.0},
    )
    c = np.array([28.0, 31.0, 45.0, 55.0, 60.0])
    cg = np.linspace(25, 65, 10)
    fleet = FleetSection(
        surface="snow",
        outcome="mu",
        c_xr=c,
        c_xr_sd=np.full(5, 1.5),
        mu=np.array([0.47, 0.44, 0.30, 0.2, 0.17]),
        tyre_type=np.array(["winter", "winter", "all_season", "summer", "summer"]),
        bands={"winter": (cg, 10 / cg, 12 / cg, 14 / cg)},
        ols={
            "intercept": -0.1,
            "slope": 16.0,
            "r2": 0.83,
            "resid_sd": 0.04,
            "n": 5,
            "band": (cg, 12 / cg - 0.1, 12 / cg, 12 / cg + 0.1),
        },
        parameters={"winter": {k: _summary(0.4, 0.02) for k in ("a", "b", "sigma")}},
        diagnostics={"converged": True},
        n_sets=5,
    )
    vmax = VmaxSection(
        vehicle="compact_fwd",
        rows=[
            {
                "tyre": "set A",
                "tyre_type": "winter",
                "c_xr": 31.0,
                "draws": rng.normal(55, 3, 100),
                "summary": _summary(55.0, 3.0),
                "measured_lo": 70.0,
                "measured_hi": 80.0,
            }
        ],
        comparison={},
    )
    amb = np.array([0.0, 7.0, 20.0, 40.0])
    curve = {
        "ambient_c": amb,
        "q05": amb * 0 + 0.9,
        "q50": 1 + amb / 100,
        "q95": 1.2 + amb / 50,
        "c_xr": 29.0,
        "tyre_type": "winter",
        "truth": 1 + amb / 80,
    }
    wear = WearSection(
        reference_c=7.0,
        curves={"baseline": {"soft": curve}, "extended": {"soft": curve}},
        kappa={"winter": {**_summary(0.02, 0.01), "true": 0.03}},
        comparison={"elpd_gain_extended": {"diff": 3.0, "se": 1.0}},
        diagnostics={},
        thesis={
            "relative_wear_difference": {"soft": 0.13, "stiff": 0.26},
            "soft_wears_relatively_more_in_heat": False,
        },
    )
    warning = {
        "decision": "winter suitability",
        "subject": "set A",
        "tyre_type": "winter",
        "quantity": "mu on snow",
        "predicted": _summary(0.42, 0.05),
        "interval_90": [0.34, 0.5],
        "event": "mu < 0.26",
        "probability": 0.004,
        "threshold": 0.1,
        "verdict": "ok",
        "reason": "fine",
    }
    return Report(
        title="test report",
        subtitle="hand-made",
        tyres=[tyre],
        fleet=fleet,
        vmax=vmax,
        wear=wear,
        warnings=[warning],
        diagnostics=[{"fit": "tyre: set A", "method": "fast", "converged": True}],
        timings={"total": {"wall_s": 1.0, "cpu_s": 0.5}},
    )


def test_write_report_files_links_and_numbers(tmp_path) -> None:
    paths = write_report(_report(), tmp_path)
    html = (tmp_path / "report.html").read_text()
    md = (tmp_path / "report.md").read_text()
    pngs = sorted((tmp_path / "figures").glob("*.png"))
    assert len(pngs) == 5 and all(p.stat().st_size > 5_000 for p in pngs)
    assert html.count("data:image/png;base64,") == 5
    for href in re.findall(r'href="([^"]+)"', html):
        assert (tmp_path / href).is_file()
    for link in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md):
        assert (tmp_path / link).is_file()
    for text in (html, md):
        assert "R² = 0.83" in text and "31 ± 1.2" in text and "0.004" in text
    summary = json.loads((tmp_path / "report.json").read_text())
    assert summary["fleet"]["ols"]["r2"] == 0.83
    assert not list(tmp_path.rglob("*.tmp*"))  # no temporary files left behind
    assert set(paths.to_dict()) >= {"report.html", "report.md", "report.json"}


def test_fmt_and_post() -> None:
    assert fmt(float("nan")) == "–" and fmt(None) == "–" and fmt(True) == "yes"
    assert fmt(0.123456) == "0.123" and fmt(3) == "3"
    assert post(_summary(1.0, 0.1)) == "1 ± 0.1 [0.836, 1.16]"


def test_inadequate_and_unconverged_fits_are_marked(tmp_path) -> None:
    report = _report()
    report.diagnostics.append(
        {
            "fit": "fleet: winter",
            "method": "nuts",
            "chains": 2,
            "converged": False,
            "reason": "tail ESS 171 < 200",
            "adequate": False,
            "adequacy_reasons": ["mu: observed sd outside its posterior predictive (p = 0.001)"],
        }
    )
    header, rows = diagnostics_table(report)
    row = dict(zip(header, rows[-1], strict=True))
    assert row["converged"] == "no" and row["adequate"] == "NO"
    assert "tail ESS" in row["note"] and "observed sd" in row["note"]
    assert dict(zip(header, rows[0], strict=True))["adequate"] == "yes"
    lines = headline(report)
    assert any("not: fleet: winter" in line for line in lines)
    assert any(line.startswith("Model inadequate") and "fleet: winter" in line for line in lines)
    write_report(report, tmp_path)
    assert "Model inadequate" in (tmp_path / "report.md").read_text()


def test_vmax_row_with_draws_below_the_search_range_says_so() -> None:
    from tyrebayes.report.tables import vmax_table

    report = _report()
    row = report.vmax.rows[0]
    assert "lowest speed searched" not in vmax_table(report)[1][0][4]
    row.update(below_range=60, above_range=0)
    assert "60 of 100 draws fail at the lowest speed searched" in vmax_table(report)[1][0][4]
