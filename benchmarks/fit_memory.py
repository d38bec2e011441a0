"""Peak memory of ``tyrebayes fit-tyre`` as a user runs it: one process per fit, one-hour drive.

``tyre_speed.py`` measures the fits inside one benchmark process that also simulated the drives, so
its peak includes the simulator's arrays and every earlier compilation. Here the drive is written to
Parquet first and each method runs in a fresh ``tyrebayes fit-tyre`` process; its peak resident set
size (its own ``VmHWM`` at exit, :mod:`_cli_child`) is what a user's machine needs. Each method runs
twice on an empty JAX compilation cache: ``cold`` compiles the model (XLA's compiler works in the
same process), ``warm`` loads the compiled program from the cache, as every later fit of that data
shape on the machine does. Target: ≤ 2 GB per one-hour fit (as in ``tyre_speed.py``).

Usage: ``python benchmarks/fit_memory.py [--out FILE] [--methods fast,nuts]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _cli_child import cli_command, peak_mb  # noqa: E402
from _results import figure, write_result  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "fit_memory.json"
TARGET_PEAK_MB = 2048.0
HOUR_S = 3600.0
VEHICLE = "compact_fwd"


def write_drive(path: Path, seed: int) -> float:
    """Simulate a one-hour 100 Hz drive with two ABS stops, write it; returns the true mean C_x."""
    import numpy as np

    from tyrebayes import load_vehicle
    from tyrebayes.simulate import ProfileOptions, simulate_drive

    df, truth = simulate_drive(
        seed,
        load_vehicle(VEHICLE),
        "all_season",
        duration_s=HOUR_S,
        profile=ProfileOptions(n_abs_events=2),
        ambient_c=15.0,
    )
    df.to_parquet(path)
    return float(np.mean(truth.c_x))


def run_fit(stream: Path, method: str, out: Path, cache: Path) -> dict:
    """One ``fit-tyre`` process: wall time, exit status, peak RSS [MB] and its C_x summary."""
    cmd = cli_command([
        "fit-tyre", str(stream),
        "--vehicle", VEHICLE, "--method", method, "--ambient", "15",
        "--out", str(out), "--json",
    ])  # fmt: skip
    t0 = time.perf_counter()
    env = {**os.environ, "TYREBAYES_JAX_CACHE": str(cache)}
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    record = {"method": method, "exit_status": proc.returncode, "wall_s": wall}
    record["peak_rss_mb"] = peak_mb(proc.stderr)
    record["target_met"] = bool(record["peak_rss_mb"] <= TARGET_PEAK_MB)
    if proc.returncode in (0, 3):
        summary = json.loads(proc.stdout)
        record["c_x"] = summary.get("c_x")
        record["converged"] = summary.get("diagnostics", {}).get("converged")
    else:
        record["stderr_tail"] = proc.stderr[-500:]
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(RESULTS))
    parser.add_argument("--methods", default="fast,nuts")
    parser.add_argument("--seed", type=int, default=11)
    parser.add_argument("--write-drive", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.write_drive:
        print(write_drive(Path(args.write_drive), args.seed))
        return
    res: dict = {
        "description": __doc__.splitlines()[0],
        "vehicle": VEHICLE,
        "drive_duration_s": HOUR_S,
        "sample_rate_hz": 100.0,
        "target_peak_mb": TARGET_PEAK_MB,
        "cpu_count": os.cpu_count(),
        "load_average_start": list(os.getloadavg()),
        "fits": [],
    }
    with tempfile.TemporaryDirectory() as tmp:
        stream = Path(tmp) / "drive.parquet"
        # The drive is written by a child process, so that the simulator's memory is no fit's.
        written = subprocess.run(
            [sys.executable, __file__, "--write-drive", str(stream), "--seed", str(args.seed)],
            capture_output=True,
            text=True,
            check=True,
        )
        res["c_x_true"] = float(written.stdout.split()[-1])
        for method in args.methods.split(","):
            for cache_state in ("cold", "warm"):
                cache = Path(tmp) / f"cache-{method}"
                record = run_fit(stream, method, Path(tmp) / f"{method}.nc", cache)
                record["cache"] = cache_state
                res["fits"].append(record)
                print(
                    f"{method} ({cache_state} cache): exit {record['exit_status']}, "
                    f"{record['wall_s']:.1f} s, peak {record['peak_rss_mb']:.0f} MB "
                    f"({'met' if record['target_met'] else 'MISSED'} ≤ {TARGET_PEAK_MB:.0f} MB)",
                    flush=True,
                )
    res["load_average_end"] = list(os.getloadavg())
    figures = [
        figure(
            f"fit-tyre --method {r['method']} on a one-hour drive, fresh process, {r['cache']} "
            "JAX cache: peak RSS of the process",
            r["peak_rss_mb"],
            unit="MB",
            target=("<=", TARGET_PEAK_MB),
            count=1,
            note="" if r["exit_status"] == 0 else f"exit status {r['exit_status']}",
        )
        for r in res["fits"]
    ]
    print(f"saved {write_result('fit_memory', res, figures=figures, path=args.out)}")


if __name__ == "__main__":
    main()
