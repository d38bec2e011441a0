"""Wall and CPU time to simulate a drive (stream + truth), brush and Magic Formula truth.

The per-tyre benchmark needs 50+ one-hour 100 Hz drives per setting, so one drive must take well
under a couple of seconds. Measures the first call (includes compiling the thermal scan) and the
median of repeated calls, for 1 h and 3 h (linearity), and the process's peak resident memory.

Usage: ``python benchmarks/simulate_speed.py [--quick]`` (``--quick``: 10 min and 1 h, 2 repeats).
Writes ``benchmarks/results/simulate_speed.json``.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

import jax
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

from tyrebayes.simulate import ProfileOptions, simulate_drive  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def _time_one(seed: int, hours: float, model: str) -> tuple[float, float, int]:
    wall, cpu = time.perf_counter(), time.process_time()
    df, _ = simulate_drive(
        seed,
        "suv_rav4",
        "all_season",
        duration_s=3600.0 * hours,
        ambient_c=10.0,
        tyre_model=model,
        profile=ProfileOptions(abs_events_per_hour=4.0),
    )
    return time.perf_counter() - wall, time.process_time() - cpu, len(df)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    durations = (1 / 6, 1.0) if args.quick else (1.0, 3.0)
    repeats = 2 if args.quick else 3
    rows = []
    for model in ("brush", "magic_formula"):
        for hours in durations:
            first = _time_one(0, hours, model)
            again = [_time_one(i + 1, hours, model) for i in range(repeats)]
            walls = sorted(w for w, _, _ in again)
            cpus = sorted(c for _, c, _ in again)
            rows.append(
                {
                    "tyre_model": model,
                    "hours": hours,
                    "samples": first[2],
                    "first_call_wall_s": first[0],
                    "median_wall_s": walls[len(walls) // 2],
                    "median_cpu_s": cpus[len(cpus) // 2],
                }
            )
            r = rows[-1]
            print(
                f"{model:14s} {hours:5.2f} h {r['samples']:>9d} samples: "
                f"first {r['first_call_wall_s']:.2f} s,"
                f" then wall {r['median_wall_s']:.2f} s, cpu {r['median_cpu_s']:.2f} s"
            )
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    load = os.getloadavg()[0]
    print(f"peak RSS {peak_mb:.0f} MB; 1-min load average {load:.1f} on {os.cpu_count()} CPUs")
    result = {
        "description": __doc__.splitlines()[0],
        "rows": rows,
        "peak_rss_mb": peak_mb,
        "load_average_1min": load,
        "cpu_count": os.cpu_count(),
    }
    RESULTS.mkdir(parents=True, exist_ok=True)
    out = write_result("simulate_speed", result, quick=args.quick or None)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
