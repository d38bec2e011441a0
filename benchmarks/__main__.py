"""Run the benchmarks: ``python -m benchmarks NAME [ARGS...]``, ``--all``, ``--quick``, ``--list``.

Each benchmark is a script ``benchmarks/NAME.py``; this runner starts it in a fresh Python process
from the repository root (``python benchmarks/NAME.py ARGS``), so that its peak memory and its
compiled programs are its own, and the script writes ``benchmarks/results/NAME.json`` through
:func:`benchmarks._results.write_result` (the shared results schema: name, code revision, date,
machine, wall and CPU seconds, peak RSS, headline figures).

Usage::

    python -m benchmarks --list                  # the benchmarks, their full and quick arguments
    python -m benchmarks tyre_speed              # one benchmark at its measured size
    python -m benchmarks tyre_recovery --quick   # its reduced run: results/quick/tyre_recovery.json
    python -m benchmarks vmax -- --quick         # arguments after -- go to the script as they are
    python -m benchmarks --all --quick           # every benchmark that has a quick mode
    python -m benchmarks --all                   # everything, at full size: hours on 2 cores

A quick run writes under ``benchmarks/results/quick/`` (git ignores it), so a smoke test never
replaces a measured figure. ``--all`` goes on past a failed benchmark and exits 1 at the end if
any failed.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

# The environment variable the runner sets for a quick run; ``write_result`` reads it.
from ._results import QUICK_ENV

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


@dataclass(frozen=True)
class Benchmark:
    """One benchmark script: the arguments of its measured run and of its quick run.

    ``quick`` is ``None`` for a benchmark without a reduced mode (``--quick`` skips it).
    """

    name: str
    what: str
    full: tuple[str, ...] = ()
    quick: tuple[str, ...] | None = None
    minutes: float = field(default=0.0, compare=False)  # rough full-size wall time on 2 cores


BENCHMARKS: dict[str, Benchmark] = {
    b.name: b
    for b in [
        # accuracy on data the package did not make
        Benchmark(
            "external_drives",
            "fit the 16 independent drives, compare with their truth",
            quick=("--drives", "e00,e01"),
            minutes=15,
        ),
        Benchmark(
            "identification", "drives that cannot measure C_x, or contradict their label", minutes=5
        ),
        Benchmark(
            "lateral_external",
            "lateral fit and a paramsd-style EKF on the 8 independent cornering drives",
            quick=("--drives", "l00,l04"),
            minutes=5,
        ),
        Benchmark(
            "lateral_real",
            "lateral fit on real cars against a stiffness fitted with the measured v_y",
            minutes=3,
        ),
        Benchmark(
            "lateral_simulated_drives",
            "lateral fit on the package's longitudinal drive simulator: the gap and the flag",
            quick=("--seeds", "2"),
            minutes=4,
        ),
        Benchmark(
            "lateral_effects",
            "each nuisance of the lateral model: ELPD gain and error change",
            quick=("--drives", "l00"),
            minutes=20,
        ),
        Benchmark(
            "real_log_fit", "the real 60 s RAV4 log, NUTS", quick=("--method", "fast"), minutes=5
        ),
        Benchmark(
            "real_log_features",
            "the real RAV4 log's features against GNSS",
            quick=("--quick",),
            minutes=1,
        ),
        Benchmark(
            "real_vs_sim",
            "the simulator's sensors against the real log",
            quick=("--quick",),
            minutes=2,
        ),
        # accuracy on the package's own simulator
        Benchmark(
            "tyre_recovery",
            "C_x and mu_max recovery, coverage, against OLS and TLS",
            quick=("--quick",),
            minutes=120,
        ),
        Benchmark(
            "shape_prior",
            "what the curve's shape prior does to C_x",
            quick=("--reps", "2"),
            minutes=60,
        ),
        Benchmark(
            "block_offsets",
            "the 5 s block slip offsets on drifting drives",
            quick=("--seeds", "1000-1000", "--duration", "300"),
            minutes=20,
        ),
        Benchmark(
            "fleet_vs_ols",
            "hierarchical fleet model against the thesis' OLS line",
            quick=("--quick",),
            minutes=30,
        ),
        Benchmark(
            "fleet_nuts",
            "the fleet model's NUTS: convergence, refit time",
            quick=("--fleets", "2"),
            minutes=20,
        ),
        Benchmark(
            "fleet_lateral_ratio",
            "per-type ratio c_y / C_xr recovered over simulated fleets; straight-only V_max",
            quick=("--seeds", "2", "--no-e2e"),
            minutes=12,
        ),
        Benchmark(
            "discovery",
            "calibrated discovery: power and FDR on simulated fleets",
            quick=("--fleets", "4", "--null-fleets", "4", "--permutations", "99"),
            minutes=45,
        ),
        Benchmark(
            "discovery_tread",
            "the tread effect on issue 25's table set",
            quick=("--tables", "2"),
            minutes=5,
        ),
        Benchmark(
            "vmax",
            "critical lane-change speed: cost and against measured",
            quick=("--quick",),
            minutes=5,
        ),
        Benchmark(
            "vmax_lateral",
            "V_max from the lateral posterior against the external drives' true parameters",
            quick=("--drives", "l00,l01", "--draws", "200"),
            minutes=8,
        ),
        Benchmark(
            "wear_thesis", "the thesis' wear simulation and its fix", quick=("--quick",), minutes=20
        ),
        Benchmark(
            "wear_recovery",
            "wear model recovery of gamma from tread readings",
            quick=("--quick",),
            minutes=20,
        ),
        Benchmark(
            "wear_history",
            "wear from a car's drive history with cornering, 10 simulated years",
            quick=("--years", "1", "--drives", "12", "--drive-s", "300", "--samples", "200"),
            minutes=15,
        ),
        Benchmark(
            "online_agreement",
            "in-car estimator against the batch posterior",
            quick=("--sim", "2", "--duration", "300", "--no-external"),
            minutes=40,
        ),
        Benchmark(
            "online_lateral",
            "in-car lateral estimator on the 8 cornering drives: agreement, braking corners, speed",
            quick=("--drives", "l00,l04", "--reps", "1"),
            minutes=10,
        ),
        Benchmark(
            "online_change",
            "in-car estimator: tyre swaps found, false alarms",
            quick=("--swaps", "2", "--cars", "2"),
            minutes=40,
        ),
        Benchmark(
            "online_outliers",
            "in-car estimator under a burst of outliers",
            quick=("--drives", "2"),
            minutes=20,
        ),
        # speed and memory
        Benchmark(
            "lateral_speed",
            "the lateral fit of a one-hour drive on one core; fit-tyre's peak memory",
            quick=("--duration", "600"),
            minutes=5,
        ),
        Benchmark(
            "tyre_speed",
            "one-hour drive: fast fit, NUTS, peak memory, ten drives",
            quick=("--skip-nuts",),
            minutes=10,
        ),
        Benchmark(
            "fit_memory",
            "peak memory of fit-tyre in a fresh process",
            quick=("--methods", "fast"),
            minutes=5,
        ),
        Benchmark(
            "fleet_run",
            "fleet runs on Dask at the issue's size",
            ("--full",),
            quick=("--drives", "4", "--sets", "2"),
            minutes=60,
        ),
        Benchmark(
            "online_speed",
            "in-car estimator: one car-hour, vmapped cars, 10^4 cars",
            quick=("--reps", "1", "--cars", "2", "--no-fleet"),
            minutes=30,
        ),
        Benchmark(
            "online_curvature_cost",
            "the online filter's curvature pass",
            quick=("--repeats", "5"),
            minutes=2,
        ),
        Benchmark(
            "stored_program",
            "traced programs kept on disk: first fit in a new process",
            quick=("--repeats", "1"),
            minutes=5,
        ),
        Benchmark(
            "compile_backend",
            "XLA:CPU code generators: compile time of a fit",
            quick=("--repeats", "1"),
            minutes=5,
        ),
        Benchmark(
            "fit_file_io",
            "fit files: write and read time per netCDF library",
            quick=("--repeats", "2"),
            minutes=2,
        ),
        Benchmark(
            "stream_stage_speed",
            "the fleet run's per-drive stage",
            quick=("--repeats", "1"),
            minutes=5,
        ),
        Benchmark(
            "core_contention",
            "a worker's CPU time with the other core busy: the machine's share of scaling",
            quick=("--duration", "300", "--repeats", "2"),
            minutes=3,
        ),
        Benchmark(
            "drive_stage_profile",
            "the per-drive stage of a one-hour drive: CPU per step, EM, profile",
            quick=("--duration", "600", "--repeats", "1"),
            minutes=3,
        ),
        Benchmark(
            "windows_step_speed",
            "force-density EM steps against plain EM",
            quick=("--drives", "1", "--repeats", "1"),
            minutes=20,
        ),
        Benchmark("streams_speed", "stream pipeline throughput", quick=("--quick",), minutes=5),
        Benchmark("can_speed", "raw CAN log decoding throughput", quick=("--quick",), minutes=10),
        Benchmark("simulate_speed", "simulator throughput", quick=("--quick",), minutes=2),
        # the code itself
        Benchmark(
            "api_surface",
            "the public API: examples, typed results, module and function sizes, import circles",
            quick=(),
            minutes=0.2,
        ),
        Benchmark(
            "physics_speed",
            "physics functions' throughput",
            quick=("--n", "100000", "--repeats", "2"),
            minutes=2,
        ),
    ]
}


def _scripts() -> set[str]:
    return {p.stem for p in HERE.glob("[a-z]*.py")}


def registered(name: str) -> Benchmark:
    """The benchmark called ``name``; a script the table does not list runs without arguments."""
    if name in BENCHMARKS:
        return BENCHMARKS[name]
    if name in _scripts():
        return Benchmark(name, "(not in the runner's table)", quick=None)
    known = ", ".join(sorted(_scripts()))
    raise SystemExit(f"benchmarks: no benchmark {name!r}; known: {known}")


def command(bench: Benchmark, *, quick: bool, extra: list[str]) -> list[str] | None:
    """The command line that runs ``bench`` (``None``: it has no quick mode)."""
    args = bench.quick if quick else bench.full
    if args is None:
        return None
    return [sys.executable, str(HERE / f"{bench.name}.py"), *args, *extra]


def run(bench: Benchmark, *, quick: bool, extra: list[str]) -> int | None:
    """Run one benchmark in a child process; its exit status (``None``: skipped)."""
    cmd = command(bench, quick=quick, extra=extra)
    if cmd is None:
        print(f"== {bench.name}: no quick mode, skipped", flush=True)
        return None
    env = dict(os.environ)
    if quick:
        env[QUICK_ENV] = "1"
    else:
        env.pop(QUICK_ENV, None)
    shown = " ".join(cmd[1:])
    print(f"== {bench.name}: {shown}", flush=True)
    t0 = time.perf_counter()
    status = subprocess.run(cmd, cwd=ROOT, env=env).returncode
    print(f"== {bench.name}: exit {status} after {time.perf_counter() - t0:.0f} s", flush=True)
    return status


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    extra: list[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, extra = argv[:cut], argv[cut + 1 :]
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks", description=__doc__.split("\n")[0]
    )
    parser.add_argument("names", nargs="*", help="benchmarks to run (see --list)")
    parser.add_argument("--all", action="store_true", help="every benchmark script")
    parser.add_argument("--quick", action="store_true", help="the reduced runs (results/quick/)")
    parser.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    args = parser.parse_args(argv)

    if args.list:
        for b in BENCHMARKS.values():
            quick = " ".join(b.quick) if b.quick is not None else "(none)"
            print(
                f"{b.name:24s} {b.what}\n{'':24s} full: {' '.join(b.full) or '(defaults)'};"
                f" quick: {quick or '(defaults)'}; ~{b.minutes:.0f} min"
            )
        missing = sorted(_scripts() - set(BENCHMARKS))
        if missing:
            print("scripts not in the table (run without arguments):", ", ".join(missing))
        return 0
    if args.all == bool(args.names):
        parser.error("name one or more benchmarks, or --all")
    if args.all and extra:
        parser.error("arguments after -- go to one benchmark, not to --all")
    if args.all:  # the table's order, then any script it does not list
        benches = [*BENCHMARKS.values()]
        benches += [registered(n) for n in sorted(_scripts() - set(BENCHMARKS))]
    else:
        benches = [registered(n) for n in args.names]
    failed = []
    for bench in benches:
        status = run(bench, quick=args.quick, extra=extra)
        if status:
            failed.append(bench.name)
            if not args.all:
                return status
    if failed:
        print("failed:", ", ".join(failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
