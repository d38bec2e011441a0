"""Seconds and peak memory to read and process long 100 Hz streams (CSV and Parquet).

Target (issue 3): one hour of 100 Hz data read, validated and turned into features in <= 2 s
with <= 1 GB peak memory, linear in duration (1 h vs 10 h).

Each measurement runs in a fresh Python process after the imports: the time covers
``read_stream`` + ``validate_stream`` + ``compute_features`` (including JAX's first-call
dispatch), the memory is the process's peak resident set (VmHWM) minus its resident set after
the imports, i.e. what the data and the pipeline add.

Usage: python benchmarks/streams_speed.py [--quick]   (quick: 1 h only, CSV and Parquet)
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

import numpy as np
import pandas as pd
from _results import write_result  # noqa: E402

from tyrebayes import load_vehicle, write_stream
from tyrebayes.simulate import synthetic_stream

RESULTS = Path(__file__).resolve().parent / "results" / "streams_speed.json"
TARGET_S_PER_HOUR = 2.0
TARGET_MB_PER_HOUR = 1024.0

_CHILD = r"""
import json, sys, time
from tyrebayes import compute_features, load_vehicle, read_stream, validate_stream

def rss_mb(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1]) / 1024.0
vehicle = load_vehicle("compact_fwd")
base = rss_mb("VmRSS:")
t0 = time.perf_counter()
c0 = time.process_time()
df = read_stream(sys.argv[1])
t1 = time.perf_counter()
stream = validate_stream(df, vehicle)
t2 = time.perf_counter()
feats = compute_features(stream, vehicle)
t3 = time.perf_counter()
c3 = time.process_time()
print(json.dumps({
    "samples": int(feats.time_s.size),
    "read_s": t1 - t0, "validate_s": t2 - t1, "features_s": t3 - t2, "total_s": t3 - t0,
    "cpu_s": c3 - c0,
    "peak_mb": rss_mb("VmHWM:") - base, "baseline_mb": base,
    "valid_fraction": float(feats.valid.mean()),
}))
"""


def _hour_table(rate_hz: float) -> pd.DataFrame:
    vehicle = load_vehicle("compact_fwd")
    df, _ = synthetic_stream(
        vehicle, duration_s=3600.0, rate_hz=rate_hz, seed=0, drop_fraction=0.01
    )
    return df


def _tile(hour: pd.DataFrame, hours: int) -> pd.DataFrame:
    """A long log as repeated hours (time shifted); fine for throughput, not for statistics."""
    if hours == 1:
        return hour
    parts = []
    span = float(hour["time"].iloc[-1] - hour["time"].iloc[0]) + float(np.diff(hour["time"][:2])[0])
    for k in range(hours):
        part = hour.copy()
        part["time"] = part["time"] + k * span
        parts.append(part)
    return pd.concat(parts, ignore_index=True)


def _measure(path: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, str(path)], capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"measurement of {path.name} failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 h only")
    args = parser.parse_args()
    hours_list = [1] if args.quick else [1, 10]
    load_at_start = os.getloadavg()[0]
    hour = _hour_table(100.0)
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for hours in hours_list:
            table = _tile(hour, hours)
            for suffix in (".parquet", ".csv"):
                path = Path(tmp) / f"stream_{hours}h{suffix}"
                t0 = time.perf_counter()
                write_stream(table, path)
                write_s = time.perf_counter() - t0
                result = _measure(path)
                result |= {
                    "hours": hours,
                    "format": suffix.lstrip("."),
                    "file_mb": path.stat().st_size / 2**20,
                    "write_s": write_s,
                    "s_per_hour": result["total_s"] / hours,
                    "mb_per_hour": result["peak_mb"] / hours,
                }
                runs.append(result)
                print(
                    f"{hours:>3} h {result['format']:<8} {result['samples']:>9} samples  "
                    f"read {result['read_s']:.2f} s  validate {result['validate_s']:.2f} s  "
                    f"features {result['features_s']:.2f} s  total {result['total_s']:.2f} s "
                    f"(cpu {result['cpu_s']:.2f} s)  "
                    f"({result['s_per_hour']:.2f} s/h)  peak +{result['peak_mb']:.0f} MB  "
                    f"file {result['file_mb']:.0f} MB",
                    flush=True,
                )
                path.unlink()
    one_hour = [r for r in runs if r["hours"] == 1]
    summary = {
        "target_s_per_hour": TARGET_S_PER_HOUR,
        "target_mb_per_hour": TARGET_MB_PER_HOUR,
        "meets_time_target_1h": all(r["total_s"] <= TARGET_S_PER_HOUR for r in one_hour),
        "meets_memory_target_1h": all(r["peak_mb"] <= TARGET_MB_PER_HOUR for r in one_hour),
        "cpu_count": os.cpu_count(),
        "load_average_1min_at_start": load_at_start,
        "note": (
            "shared 2-core machine (other agents running): total_s is wall clock after imports, "
            "cpu_s the process CPU time (all threads); one run each"
        ),
        "runs": runs,
    }
    if len(hours_list) > 1:
        for fmt in ("parquet", "csv"):
            t1 = next(r["total_s"] for r in runs if r["hours"] == 1 and r["format"] == fmt)
            t10 = next(r["total_s"] for r in runs if r["hours"] == 10 and r["format"] == fmt)
            summary[f"ratio_10h_over_1h_{fmt}"] = t10 / t1
    print(json.dumps({k: v for k, v in summary.items() if k != "runs"}, indent=1))
    print(f"saved {write_result('streams_speed', summary, quick=args.quick or None)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
