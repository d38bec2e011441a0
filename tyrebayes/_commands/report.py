"""``tyrebayes report FIT... --out DIR [--json]``: the demo's report for the user's own fits.

Each FIT is a netCDF written by ``tyrebayes fit-tyre --out`` (a per-tyre posterior) or
``tyrebayes fit-fleet --out`` (a fleet fit). The report shows every section the fits allow:
force–slip curves and diagnostics for tyre fits; friction against 1/C_xr with the OLS line for a
fleet fit; with both, the winter-suitability warnings of the tyre sets (``--type`` gives their
tyre type). The predictive V_max covers every tyre fit that carries a lateral posterior (its
measured cornering stiffness and μ_y) and, with ``--type``, the others (type relations).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from .._domain import TYRE_TYPES
from .._errors import BadInputError
from ._common import fit_file, output_folder, print_json


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "report",
        help="HTML + Markdown report of fits written by fit-tyre/fit-fleet",
        description="Render the tyrebayes report (figures, tables, diagnostics) for one or more "
        "netCDF fits from 'fit-tyre --out' and/or 'fit-fleet --out'.",
    )
    p.add_argument("fits", nargs="+", metavar="FIT", help="netCDF fit files (.nc)")
    p.add_argument("--out", default="report_out", help="output folder (default ./report_out)")
    p.add_argument(
        "--type",
        choices=TYRE_TYPES,
        default=None,
        dest="tyre_type",
        help="tyre type of the per-tyre fits (enables warnings, and V_max of fits without a "
        "lateral posterior)",
    )
    p.add_argument("--vehicle", default="compact_fwd", help="vehicle of the V_max simulation")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
    p.set_defaults(func=run)


def _load(path: str):
    from ..inference.result import load_fit

    fit = load_fit(fit_file(path))
    if fit.kind not in ("tyre", "fleet"):
        raise BadInputError(
            f"fit {path}: expected a tyre or fleet fit (fit-tyre, fit-fleet), got a {fit.kind} fit"
        )
    return fit.kind, fit


#: Posterior draws per tyre set of the V_max section.
VMAX_DRAWS = 200


def _vmax_sets(sections, fits, tyre_type: str | None, seed: int) -> list[dict]:
    """The V_max section's sets: every tyre fit with a converged lateral posterior (its measured
    c_y and μ_y), and with ``--type`` every other one (the type relations at its C_xr)."""
    import jax

    from ..inference.tyre.result import TyreFit
    from ..inference.vmax import fit_vmax_inputs

    key = jax.random.PRNGKey(seed)
    sets = []
    for i, (section, fit) in enumerate(zip(sections, fits, strict=True)):
        tyre = TyreFit.from_fit(fit)
        measured = tyre.lateral is not None and tyre.lateral.converged
        if not (measured or tyre_type):
            continue
        inputs = fit_vmax_inputs(
            tyre, jax.random.fold_in(key, i), VMAX_DRAWS, tyre_type or "all_season"
        )
        sets.append(
            {
                "tyre": section.name,
                "tyre_type": tyre_type or "",
                "c_xr": fit.draws("c_xr"),
                "inputs": inputs,
            }
        )
    return sets


def run(args: argparse.Namespace) -> int:
    out = output_folder(args.out)
    loaded = [(path, *_load(path)) for path in args.fits]
    fleets = [(p, i) for p, kind, i in loaded if kind == "fleet"]
    tyres = [(p, i) for p, kind, i in loaded if kind == "tyre"]
    if len(fleets) > 1:
        raise BadInputError(f"fits: expected at most one fleet fit, got {len(fleets)}")

    from ..inference.tyre.result import TyreFit
    from ..report import Report, write_report
    from ..report.sections import (
        diagnostics_row,
        fleet_section,
        lateral_section,
        tyre_section,
        warning_rows,
    )
    from ..report.vmax_section import vmax_section

    t0, c0 = time.perf_counter(), time.process_time()
    report = Report(
        title="tyrebayes report",
        subtitle=f"{len(tyres)} tyre fit(s), {len(fleets)} fleet fit(s): "
        + ", ".join(Path(p).name for p, _, _ in loaded),
    )
    for p, fit in tyres:
        name = Path(p).stem
        report.tyres.append(tyre_section(fit, name, tyre_type=args.tyre_type, source=str(p)))
        lateral = TyreFit.from_fit(fit).lateral
        if lateral is not None:
            report.laterals.append(lateral_section(lateral, name))
        report.diagnostics.append(diagnostics_row(fit.diagnostics, f"tyre: {name}"))
    if fleets:
        p, fleet = fleets[0]
        report.fleet = fleet_section(fleet, seed=args.seed, source=str(p))
        report.diagnostics.append(diagnostics_row(fleet.diagnostics, f"fleet: {Path(p).stem}"))
        if tyres and args.tyre_type:
            report.warnings = warning_rows(fleet, report.tyres, seed=args.seed)
    sets = _vmax_sets(report.tyres, [fit for _, fit in tyres], args.tyre_type, args.seed)
    if sets:
        report.vmax = vmax_section(args.vehicle, sets, seed=args.seed, extended=False)
    report.timings["build"] = {
        "wall_s": time.perf_counter() - t0,
        "cpu_s": time.process_time() - c0,
    }
    paths = write_report(report, out)
    summary = {
        "out": str(out),
        "report_html": str(paths.html),
        "report_md": str(paths.markdown),
        "figures": [str(p) for _, p in paths.figures],
        "tyre_fits": len(tyres),
        "fleet_fits": len(fleets),
        "inadequate_fits": [d["fit"] for d in report.diagnostics if not d["adequate"]],
        "warnings": [
            {"subject": w["subject"], "verdict": w["verdict"], "probability": w["probability"]}
            for w in report.warnings
        ],
    }
    if args.json:
        print_json(summary)
    else:
        print(f"report: {paths.html} ({len(summary['figures'])} figures)")
    return 0
