"""Where a fleet run's per-drive stage spends its CPU: one simulated one-hour drive, profiled.

The stage's work for one drive (``tyrebayes.batch.drive_stage._windows_and_summary``: read →
validate → features → lateral fit → windows and summary) runs in a fresh single-threaded process
(OMP, BLAS and XLA's kernels one thread, as a fleet worker), once to warm up (JAX compiles the
lateral fit, the force-density EM and the temperature scan: reported apart,
``first_call_cpu_s``), then ``--repeats`` times.
Reported per drive-hour: the CPU seconds (``time.process_time``) of each step, fastest of the
repeats, and of the force-density EM inside the windows step (``deconvolve_forces``); and the
largest entries of a ``cProfile`` of one more run (its own overhead makes those slower; their
shares are what they are for).

The stage's lateral fit (``tyrebayes.batch.lateral.drive_lateral``, with the method of a fast
run: ``RunSettings().lateral_method``) is measured apart, on a
simulated one-hour cornering drive (the longitudinal drive above has too little cornering), in
another fresh process with an empty persistent compilation cache: its first call (compiled),
the fastest of ``--repeats`` calls with its programs kept, and the fastest of ``--repeats`` calls
each after :func:`tyrebayes.batch.worker_memory.drop_compiled_programs` (what a fleet worker
does when its memory budget is reached: the programs are traced again and loaded from the
cache). The process's resident memory is recorded after each.

CPU time, not wall time: the machine is shared (2 cores, other runs on them; the load averages
are recorded), which stretches wall time but changes a single-threaded process's CPU seconds far
less. With ``--before REV`` the same is measured on the package as of git revision REV, on the
same file, in turns with this checkout's: ``--rounds`` fresh processes of each, after, before,
after, before, ..., each side's figures the fastest over its rounds (this host's speed drifts
by a fifth over minutes: runs of one side after the other's compare two speeds of the host).

Usage: ``python benchmarks/drive_stage_profile.py [--duration S] [--repeats N] [--before REV]
[--rounds R] [--out PATH]``. The README's figures are the one-hour drive's; a drive of another
length (``--duration``, both drives) shows what a stage costs per drive rather than per hour
(``drive_stage_profile_20min.json``: ``--duration 1200 --out
benchmarks/results/drive_stage_profile_20min.json``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

from _results import figure, write_result

sys.path.insert(0, str(Path(__file__).parent))
from _revisions import package_at, run_child  # noqa: E402

STEPS = ("read", "validate", "features", "lateral", "windows_and_summary")
#: The drive length the README's figures are for [s].
DEFAULT_DURATION_S = 3600.0

_CHILD = r"""
import cProfile, io, json, pstats, sys, time
from tyrebayes.batch.settings import RunSettings, configure_jax
configure_jax()
from tyrebayes.batch.drive_stage import _windows_and_summary
from tyrebayes.batch.manifest import DriveItem
from tyrebayes.inference.tyre import force_density

path, repeats, top = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
item = DriveItem("d", path, "compact_fwd", "s", "", "dry", float("nan"), "")
em = {}
_deconvolve = force_density.deconvolve_forces
def timed(*args, **kwargs):
    c = time.process_time()
    mixture = _deconvolve(*args, **kwargs)
    em.update(cpu=time.process_time() - c, windows=len(args[0]), steps=int(mixture.iterations),
              converged=bool(mixture.converged))
    return mixture
force_density.deconvolve_forces = timed

def run():
    c = time.process_time()
    table, row, steps = _windows_and_summary(item, RunSettings())
    return time.process_time() - c, steps, dict(em), row

first, first_steps, first_em, row = run()
runs = [run() for _ in range(repeats)]
profile = cProfile.Profile()
profile.enable()
_windows_and_summary(item, RunSettings())
profile.disable()
stats = pstats.Stats(profile, stream=io.StringIO())
entries = []
for (file, line, name), (cc, nc, tt, ct, _) in stats.stats.items():
    short = file.split("site-packages/")[-1].split("/tyrebayes/")[-1]
    entries.append({"function": f"{short}:{line}({name})", "calls": nc,
                    "tottime_s": tt, "cumtime_s": ct})
profiled_total = max(e["cumtime_s"] for e in entries)
by_cum = sorted(entries, key=lambda e: -e["cumtime_s"])[:top]
by_own = sorted(entries, key=lambda e: -e["tottime_s"])[:top]
print(json.dumps({
    "duration_s": row["duration_s"], "samples": row["samples"], "windows": row["windows"],
    "first_call_cpu_s": first, "first_call_steps_cpu_s": first_steps,
    "first_call_em_cpu_s": first_em.get("cpu"),
    "total_cpu_s": min(r[0] for r in runs),
    "steps_cpu_s": {k: min(r[1][k] for r in runs) for k in runs[0][1]},
    "em_cpu_s": min(r[2]["cpu"] for r in runs),
    "em": {k: v for k, v in runs[-1][2].items() if k != "cpu"},
    "all_runs_total_cpu_s": [r[0] for r in runs],
    "profile": {"profiled_total_s": profiled_total, "by_cumulative": by_cum, "by_own": by_own},
}))
"""

_LATERAL_CHILD = r"""
import json, sys, time
from benchmarks._internal import configure_jax
configure_jax(sys.argv[3])
from tyrebayes import RunSettings, load_vehicle, read_stream, validate_stream
from benchmarks._internal import drive_lateral, drop_compiled_programs, rss_mb

METHOD = RunSettings().lateral_method

path, repeats = sys.argv[1], int(sys.argv[2])
vehicle = load_vehicle("compact_fwd")
frame = validate_stream(read_stream(path), vehicle).data

def run():
    c = time.process_time()
    row = drive_lateral(frame, vehicle, "dry", method=METHOD, source=path)
    return time.process_time() - c, row

first, row = run()
first_rss = rss_mb()
kept = [run()[0] for _ in range(repeats)]
kept_rss = rss_mb()
dropped, dropped_rss = [], []
for _ in range(repeats):
    drop_compiled_programs()
    dropped.append(run()[0])
    dropped_rss.append(rss_mb())
print(json.dumps({
    "duration_s": float(frame["time"].iloc[-1] - frame["time"].iloc[0]),
    "lateral_method": METHOD, "lateral_reason": row["lateral_reason"], "c_y": row["c_y"],
    "first_call_cpu_s": first, "rss_mb_after_first_call": first_rss,
    "kept_cpu_s": min(kept), "rss_mb_with_programs_kept": kept_rss,
    "after_drop_cpu_s": min(dropped), "rss_mb_after_drop_and_call": max(dropped_rss),
}))
"""

_ENV = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false",
    "JAX_ENABLE_X64": "1",
    "JAX_PLATFORMS": "cpu",
}


def _per_hour(result: dict) -> dict:
    """CPU seconds per drive-hour: the stage's steps, its total and the EM."""
    hours = result["duration_s"] / 3600.0
    steps = {k: v / hours for k, v in result["steps_cpu_s"].items()}
    return {
        **steps,
        "total": result["total_cpu_s"] / hours,
        "force_density_em": result["em_cpu_s"] / hours,
        "windows_and_summary_without_em": steps["windows_and_summary"] - result["em_cpu_s"] / hours,
    }


def _fastest(runs: list[dict]) -> dict:
    """One child's result from several children's on the same file: each figure the fastest
    (the profile and the first call from the first), every run's total kept."""
    best = min(runs, key=lambda r: r["total_cpu_s"])
    return best | {
        "first_call_cpu_s": runs[0]["first_call_cpu_s"],
        "first_call_steps_cpu_s": runs[0]["first_call_steps_cpu_s"],
        "first_call_em_cpu_s": runs[0]["first_call_em_cpu_s"],
        "profile": runs[0]["profile"],
        "steps_cpu_s": {k: min(r["steps_cpu_s"][k] for r in runs) for k in best["steps_cpu_s"]},
        "em_cpu_s": min(r["em_cpu_s"] for r in runs),
        "all_runs_total_cpu_s": [t for r in runs for t in r["all_runs_total_cpu_s"]],
        "processes": len(runs),
    }


def _drive(folder: Path, duration_s: float) -> Path:
    from tyrebayes import write_stream
    from tyrebayes.simulate import simulate_drive

    path = folder / "drive.parquet"
    df, _ = simulate_drive(1, "compact_fwd", "summer", duration_s=duration_s, surface="dry")
    write_stream(df, path)
    return path


def _cornering_drive(folder: Path, duration_s: float) -> Path:
    from tyrebayes import load_vehicle, write_stream
    from tyrebayes.simulate import simulate_cornering

    path = folder / "cornering.parquet"
    frame, _ = simulate_cornering(load_vehicle("compact_fwd"), duration_s=duration_s, seed=21)
    write_stream(frame, path)
    return path


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--duration", type=float, default=DEFAULT_DURATION_S, help="drive length [s]"
    )
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--top", type=int, default=15, help="profile entries kept")
    parser.add_argument("--before", help="git revision to compare with")
    parser.add_argument(
        "--rounds", type=int, default=None, help="processes per side (default 3 with --before, 1)"
    )
    parser.add_argument("--out", type=Path, default=None, help="JSON to write")
    args = parser.parse_args()

    results: dict = {
        "repeats": args.repeats,
        "cpu_count": os.cpu_count(),
        "note": "CPU seconds (time.process_time) of single-threaded processes, fastest of the "
        "repeats after a warm-up over the rounds' processes (with a before revision, run in turns "
        "with it), per hour of simulated 100 Hz Parquet drive; the machine is shared, so wall "
        "time is not a measure here (load averages recorded)",
        "load_average_at_start": os.getloadavg(),
    }
    with tempfile.TemporaryDirectory() as tmp:
        path = _drive(Path(tmp), args.duration)
        child_args = [path, args.repeats, args.top]
        rounds = args.rounds or (3 if args.before else 1)
        code = package_at(args.before, Path(tmp) / "before") if args.before else None
        afters, befores = [], []
        for _ in range(rounds):  # in turns: both sides see the host's drift alike
            afters.append(run_child(_CHILD, child_args, None, _ENV))
            if code is not None:
                befores.append(run_child(_CHILD, child_args, code, _ENV))
        after = _fastest(afters)
        results["rounds"] = rounds
        results["after"] = after | {"per_drive_hour_cpu_s": _per_hour(after)}
        if befores:
            before = _fastest(befores)
            results["before_revision"] = args.before
            results["before"] = before | {"per_drive_hour_cpu_s": _per_hour(before)}
        cornering = _cornering_drive(Path(tmp), args.duration)
        lateral = run_child(
            _LATERAL_CHILD, [cornering, args.repeats, Path(tmp) / "jax-cache"], None, _ENV
        )
        hours = lateral["duration_s"] / 3600.0
        results["lateral"] = lateral | {
            "per_drive_hour_cpu_s": {
                k: lateral[f"{k}_cpu_s"] / hours for k in ("first_call", "kept", "after_drop")
            }
        }
    results["load_average_at_end"] = os.getloadavg()
    per_hour = results["after"]["per_drive_hour_cpu_s"]
    em = results["after"]["em"]
    # The README's table shows the default length's figures; a run at another length is beside.
    default_length = args.duration == DEFAULT_DURATION_S
    length = (
        "one simulated hour"
        if default_length
        else f"a simulated {args.duration / 60:g}-minute drive"
    )
    figures = [
        figure(
            "per-drive stage CPU per drive-hour",
            per_hour["total"],
            unit="s",
            count=1,
            note=f"read + validate + features + lateral fit + windows and summary, {length} (its "
            "lateral fit with the programs kept)",
            headline=default_length,
        ),
        *(
            figure(f"{step} CPU per drive-hour", per_hour[step], unit="s", count=1)
            for step in STEPS
        ),
        figure(
            "force-density EM CPU per drive-hour",
            per_hour["force_density_em"],
            unit="s",
            count=1,
            note=f"{em['steps']} EM steps over {em['windows']} windows, converged: "
            f"{em['converged']}; inside the windows step",
        ),
    ]
    lateral = results["lateral"]
    figures += [
        figure(
            "lateral fit CPU per drive-hour, programs kept (a worker's steady state)",
            lateral["per_drive_hour_cpu_s"]["kept"],
            unit="s",
            count=1,
            note=f"method {lateral['lateral_method']}; {length} of cornering; resident "
            f"{lateral['rss_mb_with_programs_kept']:.0f} MB; "
            f"fit: {lateral['lateral_reason'] or 'usable'}",
            headline=default_length,
        ),
        figure(
            "lateral fit CPU per drive-hour after the worker dropped its compiled programs",
            lateral["per_drive_hour_cpu_s"]["after_drop"],
            unit="s",
            count=1,
            note="traced again and loaded from the persistent cache; resident "
            f"{lateral['rss_mb_after_drop_and_call']:.0f} MB after",
        ),
        figure(
            "lateral fit CPU per drive-hour, first call (compiled, empty cache)",
            lateral["per_drive_hour_cpu_s"]["first_call"],
            unit="s",
            count=1,
            note=f"resident {lateral['rss_mb_after_first_call']:.0f} MB after",
        ),
    ]
    if args.before:
        before = results["before"]["per_drive_hour_cpu_s"]
        figures.append(
            figure("speed-up of the per-drive stage", before["total"] / per_hour["total"], count=1)
        )
    print(json.dumps({k: v for k, v in per_hour.items()}, indent=1))
    print(f"saved {write_result('drive_stage_profile', results, figures=figures, path=args.out)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
