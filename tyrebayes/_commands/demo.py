"""``tyrebayes demo [--out DIR] [--quick] [--json]``: the whole mission, simulated and real data.

1. Simulate a small fleet: tyre sets of the three types and one over-aged winter set, several drives
   each, written as stream files (``DIR/logs``) with their truth beside them.
2. Run the stream pipeline on those logs and on the shipped real RAV4 segment.
3. Fit per-tyre posteriors (fast MAP + Laplace path; NUTS for the real segment unless ``--quick``).
4. Fit the hierarchical fleet model to a simulated winter test fleet (thesis Sec. 6.1 design, with
   the hidden tyre-age effect switched on), beside the thesis' OLS line.
5. Predict V_max (Table 6.2 sets and the demo sets), wear against temperature (baseline vs
   extended), issue warnings, criticise the fleet table and the real stream.
6. Write ``DIR/report.html`` (self-contained), ``DIR/report.md``, ``DIR/report.json`` and
   ``DIR/figures/*.png``; the fits are kept as ``DIR/fits/*.nc`` for ``tyrebayes report``.
"""

from __future__ import annotations

import argparse
import sys
import time

from ..internal.jax_cache import enable_compilation_cache
from ._common import output_folder, print_json


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "demo",
        help="simulate a fleet, fit everything, write an HTML + Markdown report",
        description="End-to-end demo on simulated drives and the shipped real RAV4 segment. "
        "Most of a first run is compilation, which JAX's cache keeps for the next run "
        "(--quick: a smaller fleet, fast fits only).",
    )
    p.add_argument(
        "--out",
        default="demo_out",
        help="output folder (default ./demo_out; created with its parents)",
    )
    p.add_argument("--quick", action="store_true", help="smaller fleet, fast fits only")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
    p.set_defaults(func=run)


class _Steps:
    """A tqdm bar over the demo's steps (stderr) that also records each step's seconds."""

    def __init__(self, names: list[str], enabled: bool = True):
        from tqdm import tqdm

        self.bar = tqdm(
            total=len(names),
            desc="demo",
            file=sys.stderr,
            disable=not enabled,
            unit="step",
            dynamic_ncols=True,
        )
        self.timings: dict[str, float] = {}
        self.cpu: dict[str, float] = {}
        self._t = time.perf_counter()
        self._c = time.process_time()
        self._name = None

    def start(self, name: str) -> None:
        self._name = name
        self._t = time.perf_counter()
        self._c = time.process_time()
        self.bar.set_postfix_str(name)

    def done(self) -> None:
        self.timings[self._name] = time.perf_counter() - self._t
        self.cpu[self._name] = time.process_time() - self._c
        self.bar.update(1)

    def close(self) -> None:
        self.bar.close()


def run(args: argparse.Namespace) -> int:
    out = output_folder(args.out)
    import numpyro

    numpyro.set_host_device_count(2)
    import jax

    jax.config.update("jax_enable_x64", True)
    enable_compilation_cache()  # the demo is compile-bound on a small machine
    from ..report import write_report
    from ._demo_report import run_demo

    t0, c0 = time.perf_counter(), time.process_time()
    report, fits = run_demo(out, quick=args.quick, seed=args.seed, step_factory=_Steps)
    for name, fit in fits.items():
        fit.save(out / "fits" / f"{name}.nc")
    t_write, c_write = time.perf_counter(), time.process_time()
    paths = write_report(report, out)
    report.timings["write report"] = {
        "wall_s": time.perf_counter() - t_write,
        "cpu_s": time.process_time() - c_write,
    }
    total = time.perf_counter() - t0
    report.timings["total"] = {"wall_s": total, "cpu_s": time.process_time() - c0}
    paths = write_report(report, out)  # again, with the final timings in it
    summary = {
        "out": str(out),
        "quick": bool(args.quick),
        "seconds": total,
        "report_html": str(paths.html),
        "report_md": str(paths.markdown),
        "figures": [str(p) for _, p in paths.figures],
        "fits": [str(out / "fits" / f"{n}.nc") for n in fits],
        "tyres": {
            t.name: {"c_xr": t.summary["c_xr"], "converged": bool(t.diagnostics.get("converged"))}
            for t in report.tyres
        },
        "fleet_ols_r2": report.fleet.ols["r2"] if report.fleet else None,
        "warnings": [
            {"subject": w["subject"], "verdict": w["verdict"], "probability": w["probability"]}
            for w in report.warnings
        ],
        "criticism_found": {c["title"]: c["found"] for c in report.criticism},
        "timings_s": report.timings,
    }
    if args.json:
        print_json(summary)
    else:
        print(f"demo finished in {total:.0f} s: {paths.html}")
        print(
            f"  markdown {paths.markdown}, {len(summary['figures'])} figures, "
            f"{len(fits)} fits in {out / 'fits'}"
        )
        for w in report.warnings:
            print(f"  {w['subject']}: {w['verdict']} (P = {w['probability']:.2f})")
    return 0
