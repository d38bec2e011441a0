"""What a fleet worker's CPU time becomes when the machine's other core runs a worker too.

The scaling figure of ``fleet_run`` (one worker on one core against two workers on two cores)
counts, among what two workers lose, their tasks' CPU seconds beyond the one-worker run's
(``scaling_shortfall_core_seconds``). Part of that is software (each worker process traces and
loads the programs its first tasks need), part the machine: two processes on its two cores
share its caches, memory bandwidth and, on a virtual machine, whatever the host puts under the
cores. This benchmark measures the machine's part alone: the per-drive stage
(:func:`tyrebayes.batch.process_drive`, a fast run's settings) on one simulated drive, repeated
in one worker-like process (its programs traced and compiled by two untimed calls), first
alone, then in two such processes at once. Figures: the CPU seconds of one call alone and beside
the other process (medians of the repeats after two untimed calls; the two processes' calls
pooled), their ratio, and the ratio of the calls' wall times.

Usage: ``python benchmarks/core_contention.py [--duration S] [--repeats N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from _internal import _worker_env
from _results import figure, write_result

_CHILD = r"""
import json, sys, tempfile, time
from tyrebayes.batch import RunSettings, process_drive, read_manifest

manifest, repeats, cache = sys.argv[1], int(sys.argv[2]), sys.argv[3]
item = read_manifest(manifest)[0]
settings = RunSettings(jax_cache=cache)

def run():
    with tempfile.TemporaryDirectory() as out:
        c, w = time.process_time(), time.perf_counter()
        record = process_drive(item, out, settings)
        return time.process_time() - c, time.perf_counter() - w, record["status"]

run(), run()  # trace and compile (or load) the drive's programs; settle the heap
calls = [run() for _ in range(repeats)]
print(json.dumps({"cpu_s": [c[0] for c in calls], "wall_s": [c[1] for c in calls],
                  "status": [c[2] for c in calls]}))
"""


def _children(manifest: Path, repeats: int, cache: str, n: int) -> list[dict]:
    """``n`` measurement processes started together; each one's JSON result."""
    env = {**os.environ, **_worker_env()}
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _CHILD, str(manifest), str(repeats), cache],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        for _ in range(n)
    ]
    results = []
    for proc in procs:
        out, err = proc.communicate()
        if proc.returncode != 0:
            raise RuntimeError(f"measurement failed:\n{err}")
        results.append(json.loads(out.strip().splitlines()[-1]))
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=1800.0, help="drive length [s]")
    parser.add_argument("--repeats", type=int, default=10)
    args = parser.parse_args()

    import pandas as pd

    from tyrebayes import write_stream
    from tyrebayes.simulate import simulate_drive

    load = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        df, truth = simulate_drive(1, "compact_fwd", "summer", duration_s=args.duration)
        write_stream(df, folder / "drive.parquet")
        manifest = folder / "manifest.csv"
        row = {"path": "drive.parquet", "vehicle": "compact_fwd", "tyre_set_id": "s",
               "tyre_type": "summer", "surface": truth.surface}  # fmt: skip
        pd.DataFrame([row]).to_csv(manifest, index=False)
        cache = str(folder / "jax_cache")
        # Fills the compilation cache, so that both timed runs load what they need alike.
        _children(manifest, 1, cache, 1)
        alone = _children(manifest, args.repeats, cache, 1)
        pair = _children(manifest, args.repeats, cache, 2)
    statuses = {s for r in alone + pair for s in r["status"]}
    if statuses != {"done"}:
        raise RuntimeError(f"the drive's stage did not finish: {sorted(statuses)}")
    cpu_alone = statistics.median(alone[0]["cpu_s"])
    cpu_pair = statistics.median([c for r in pair for c in r["cpu_s"]])
    ratio = cpu_pair / cpu_alone
    wall_ratio = statistics.median([w for r in pair for w in r["wall_s"]]) / statistics.median(
        alone[0]["wall_s"]
    )
    results = {
        "duration_s": args.duration,
        "repeats": args.repeats,
        "alone": alone[0],
        "pair": pair,
        "cpu_s_per_call_alone": cpu_alone,
        "cpu_s_per_call_beside_another": cpu_pair,
        "cpu_ratio_beside_another": ratio,
        "wall_ratio_beside_another": wall_ratio,
        "cpu_count": os.cpu_count(),
        "load_average_at_start": load,
        "load_average_at_end": os.getloadavg(),
        "note": "per-drive stage of a fast run on one simulated drive, in worker-like "
        "processes (one task thread); medians of the repeats after an untimed first call",
    }
    count = args.repeats
    figures = [
        figure(
            "per-drive stage CPU per call, one worker process alone",
            cpu_alone,
            unit="s",
            count=count,
            note=f"one simulated {args.duration / 60:.0f}-min drive",
        ),
        figure(
            "per-drive stage CPU per call, two worker processes at once",
            cpu_pair,
            unit="s",
            count=2 * count,
        ),
        figure(
            "CPU time beside another worker / alone (the machine's share of the scaling loss)",
            ratio,
            count=3 * count,
            note="alone, the process's helper threads (Parquet reading, XLA's runtime) also run "
            "on the free core and count in its CPU time",
            headline=True,
        ),
        figure(
            "wall time per call beside another worker / alone",
            wall_ratio,
            count=3 * count,
        ),
    ]
    print(json.dumps({k: v for k, v in results.items() if k not in ("alone", "pair")}, indent=1))
    print(f"saved {write_result('core_contention', results, figures=figures)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
