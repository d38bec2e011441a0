"""Speed and memory of the lateral fit: a one-hour drive on one core, and the whole command.

1. The lateral part of a one-hour drive's fast fit (``cornering_observations`` + ``fit_lateral``,
   Laplace) in this process held to one core (affinity set before JAX starts, XLA's CPU thread
   pools at one thread): compile time, then the median of three fits after compilation
   (target ≤ 2 s), as the process's CPU time (the headline: on a machine shared with other
   work the wall time also counts the waits for the core) and as wall time.
2. ``tyrebayes fit-tyre STREAM --method fast --json`` on a one-hour drive in a fresh child
   process with an empty JAX compilation cache (a first fit): wall time and the child's peak RSS
   (the whole fit: reading, validation, longitudinal and lateral fits, their compilation;
   target ≤ 2 GB). The drive is a drive of the fleet's simulator (``simulate_tyre_set_drives``:
   normal driving with cornering and two ABS stops), so that both fits have their data: on the
   cornering simulator's drive, without braking, the longitudinal fit need not converge.

The lateral fit's drive is the package's cornering simulator's (``simulate_cornering``, mixed,
3,600 s at 100 Hz). A drive over 21 minutes is fitted on its 21 minutes of stretches with the most
cornering (``fit_lateral``), so the fit's cost is that of 21 minutes of data for any longer
drive.

Usage: ``python benchmarks/lateral_speed.py [--duration 3600]``.
"""

from __future__ import annotations

import os

os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
os.environ["XLA_FLAGS"] = (
    os.environ.get("XLA_FLAGS", "")
    + " --xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
)

import argparse  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import jax  # noqa: E402
from _cli_child import cli_command, peak_mb  # noqa: E402
from _internal import peak_rss_mb, reset_peak_rss, rss_mb  # noqa: E402
from _results import figure, write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from tyrebayes import cornering_observations, fit_lateral, load_vehicle  # noqa: E402
from tyrebayes.simulate import (  # noqa: E402
    ProfileOptions,
    simulate_cornering,
    simulate_tyre_set_drives,
    write_drive,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=3600.0)
    args = parser.parse_args()
    vehicle = load_vehicle("compact_fwd")
    frame, _ = simulate_cornering(vehicle, duration_s=args.duration, seed=21)
    start = time.perf_counter()
    obs = cornering_observations(frame, vehicle)
    observations_s = time.perf_counter() - start
    # The first fit's own peak above what the process held, as a fleet worker counts a task's
    # (its drive stage runs this fit on every drive that cornered).
    reset_peak_rss()
    start_mb = rss_mb()
    start = time.perf_counter()
    fit_lateral(obs)
    first_s = time.perf_counter() - start
    first_rise_mb = peak_rss_mb() - start_mb
    times, cpu_times = [], []
    for seed in range(3):
        start, cpu = time.perf_counter(), time.process_time()
        fit = fit_lateral(obs, seed=seed)
        times.append(time.perf_counter() - start)
        cpu_times.append(time.process_time() - cpu)
    after = float(np.median(cpu_times))
    del frame
    with tempfile.TemporaryDirectory() as tmp:
        stream = Path(tmp) / "hour.parquet"
        ((drive, truth),) = simulate_tyre_set_drives(
            21,
            "compact_fwd",
            "all_season",
            n_drives=1,
            duration_s=[args.duration],
            surfaces=["dry"],
            profile=[ProfileOptions(n_abs_events=2)],
        )
        write_drive(drive, truth, stream)
        del drive
        start = time.perf_counter()
        command = ["fit-tyre", str(stream), "--vehicle", "compact_fwd", "--method", "fast"]
        child = subprocess.run(
            cli_command([*command, "--json"]),
            capture_output=True,
            text=True,
            env={**os.environ, "TYREBAYES_JAX_CACHE": str(Path(tmp) / "jax-cache")},
        )
        command_s = time.perf_counter() - start
    # the child's own peak: its ru_maxrss would start from this process's (_cli_child)
    peak = peak_mb(child.stderr)
    payload = {
        "duration_s": args.duration,
        "samples_decimated": int(obs.speed.shape[0]),
        "observations_s": observations_s,
        "first_fit_s_with_compilation": first_s,
        "first_fit_peak_rise_mb": first_rise_mb,
        "fit_s_after_compilation": times,
        "fit_cpu_s_after_compilation": cpu_times,
        "shared_machine": "timings taken on a 2-core machine shared with other work",
        "converged": fit.converged,
        "command_drive": "simulate_tyre_set_drives(21, compact_fwd, all_season, one hour, dry, "
        "2 ABS stops)",
        "command_exit_status": child.returncode,
        "command_wall_s": command_s,
        "command_peak_rss_mb": peak,
        "command_stderr_tail": child.stderr[-500:],
    }
    figures = [
        figure(
            "lateral fit of a one-hour drive after compilation, one core: CPU time",
            after,
            unit="s",
            target=("<=", 2.0),
            count=3,
            headline=True,
            note="median of three fits; shared machine",
        ),
        figure(
            "the same fits' wall time",
            float(np.median(times)),
            unit="s",
            count=3,
            note="shared machine: includes waits for the core",
        ),
        figure("its first fit, compilation included", first_s, unit="s", count=1),
        figure(
            "its first fit's peak memory above the process's at its start (compilation included)",
            first_rise_mb,
            unit="MB",
            count=1,
            note="what the fit adds to a fleet worker's drive task (VmHWM after a reset)",
        ),
        figure(
            "fit-tyre --method fast on a one-hour drive, fresh process, empty JAX cache: "
            "peak RSS of the process",
            peak,
            unit="MB",
            target=("<=", 2048.0),
            count=1,
            exclusions=[] if child.returncode == 0 else [f"exit status {child.returncode}"],
            note=f"the fleet simulator's drive (braking and cornering); exit status "
            f"{child.returncode}, {command_s:.0f} s wall",
        ),
    ]
    path = write_result("lateral_speed", payload, figures=figures)
    print(payload, f"wrote {path}")


if __name__ == "__main__":
    main()
