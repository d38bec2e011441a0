"""Seconds and peak memory from a raw CAN log of a full bus to a validated stream.

Target (issue 22), candump: one hour of a full bus (about 2,500 frames/s, 9 million frames, of
which the profile needs about 10 %) decoded to a stream in <= 20 s on one core with <= 1 GB,
linear in length, and >= 10x faster than python-can's line reader with cantools' per-frame
decoding. BLF and ASC (python-can's readers, the supported path for them) are measured beside it.

The bus: the RAV4 profile's messages (WHEEL_SPEEDS, KINEMATICS, STEER_ANGLE_SENSOR at 80 Hz,
SPEED at 10 Hz: 250 frames/s) encoded by cantools from a simulated 10-minute drive and repeated
over the hour, plus 2,250 frames/s of 45 other 8-byte DBC messages with random payloads at
random phases. candump text is written with NumPy, BLF and ASC with python-can's writers.

Each measurement runs in a fresh, single-threaded Python process (its CPU time never exceeds its
wall time: one core; not pinned, so that the scheduler can move it off a core another process
holds), candump and the per-frame path the fastest of three runs as the machine is shared. The
speed-up is judged on CPU time, which others' load on the shared machine does not inflate; wall
times are reported beside it: the time covers
``read_can_log`` (read, decode) + ``validate_stream`` (one time base); the memory is the peak
resident set of the process (``VmHWM``: ``resource.getrusage``'s ``ru_maxrss`` is kept too but
Linux carries it over from the forking parent, which holds the synthesised bus) and that minus
the resident set after the imports. The
per-frame path (``can.LogReader`` + ``Message.decode`` for the profile's frames) runs on the
first 5 minutes of the same log and is scaled to the hour. ASC is measured on the first
10 minutes (python-can's ASC writer and reader need minutes per hour) and scaled.

Usage: python benchmarks/can_speed.py [--quick]   (quick: 15 minutes of bus only)
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
from _results import write_result  # noqa: E402

from tyrebayes import load_profile, load_vehicle
from tyrebayes.simulate import stream_messages, synthetic_stream
from tyrebayes.streams.can import load_dbc

RESULTS = Path(__file__).resolve().parent / "results" / "can_speed.json"
TARGET_S_PER_HOUR = 20.0
TARGET_MB = 1024.0
TARGET_SPEEDUP = 10.0
PROFILE = "toyota_rav4_2017"
EPOCH_S = 1_700_000_000.0
BLOCK_S = 600.0  # the encoded drive repeated over the hour
PROFILE_HZ = {"WHEEL_SPEEDS": 80, "KINEMATICS": 80, "STEER_ANGLE_SENSOR": 80, "SPEED": 10}
FILLER_HZ = 2250.0
SLOW_SLICE_S = 300.0
ASC_SLICE_S = 600.0
REPEATS = 3  # candump and per-frame runs: the fastest of three; BLF and ASC: one run

_CHILD = r"""
import json, os, resource, sys, time
from tyrebayes import load_vehicle, read_can_log, validate_stream

def rss_mb(key="VmRSS:"):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1]) / 1024.0
vehicle = load_vehicle("suv_rav4")
base = rss_mb()
t0, c0 = time.perf_counter(), time.process_time()
conv = read_can_log(sys.argv[1], sys.argv[2])
t1 = time.perf_counter()
stream = validate_stream(conv.data, vehicle)
t2, c2 = time.perf_counter(), time.process_time()
peak = rss_mb("VmHWM:")
print(json.dumps({
    "ru_maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    "frames_read": conv.counts.frames, "frames_used": conv.counts.kept,
    "frames_per_message": conv.frames_per_message, "samples": int(stream.data.shape[0]),
    "decode_s": t1 - t0, "validate_s": t2 - t1, "total_s": t2 - t0, "cpu_s": c2 - c0,
    "peak_rss_mb": peak, "baseline_mb": base, "peak_over_baseline_mb": peak - base,
}))
"""

_SLOW_CHILD = r"""
import json, os, resource, sys, time
import can, numpy as np
from tyrebayes.streams.can import load_dbc, load_profile
profile = load_profile(sys.argv[2])
db = load_dbc(profile.dbc_path())
messages = {db.get_message_by_name(ch.message).frame_id: db.get_message_by_name(ch.message)
            for ch in profile.channels}
t0, c0 = time.perf_counter(), time.process_time()
n = 0
decoded = {m.name: [] for m in messages.values()}
with can.LogReader(sys.argv[1]) as reader:
    for msg in reader:
        n += 1
        spec = messages.get(msg.arbitration_id)
        if spec is None or msg.is_error_frame or msg.is_remote_frame:
            continue
        decoded[spec.name].append((msg.timestamp, spec.decode(msg.data, decode_choices=False)))
t1, c1 = time.perf_counter(), time.process_time()
print(json.dumps({
    "frames_read": n, "frames_used": sum(len(v) for v in decoded.values()),
    "total_s": t1 - t0, "cpu_s": c1 - c0,
    "ru_maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    "peak_rss_mb": [int(l.split()[1]) / 1024.0 for l in open("/proc/self/status")
                    if l.startswith("VmHWM:")][0],
}))
"""


def _profile_block() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The profile's frames of a 10-minute drive, encoded by cantools: (time, id, data)."""
    vehicle = load_vehicle("suv_rav4")
    profile = load_profile(PROFILE)
    db = load_dbc(profile.dbc_path())
    df, _ = synthetic_stream(vehicle, duration_s=BLOCK_S, rate_hz=80.0, seed=0)
    every = {name: 80 // hz for name, hz in PROFILE_HZ.items()}
    msgs = stream_messages(df, profile, db, wheel_radius_m=vehicle.wheel_radius_m, every=every)
    # Each message at its own phase in the 12.5 ms cycle, as ECUs send them.
    offset = {0xAA: 0.0, 0x24: 0.0031, 0x25: 0.0062, 0xB4: 0.0093}
    t = np.array([m.timestamp + offset[m.arbitration_id] for m in msgs])
    ids = np.array([m.arbitration_id for m in msgs], dtype=np.int64)
    data = np.frombuffer(b"".join(bytes(m.data) for m in msgs), dtype=np.uint8).reshape(-1, 8)
    return t, ids, data


def _bus(seconds: float, block) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A full bus of ``seconds``: the profile block repeated plus filler frames, time-sorted."""
    rng = np.random.default_rng(1)
    t_b, id_b, d_b = block
    reps = int(np.ceil(seconds / BLOCK_S))
    t_p = np.concatenate([t_b + k * BLOCK_S for k in range(reps)])
    keep = t_p < seconds
    t_p, id_p = t_p[keep], np.tile(id_b, reps)[keep]
    d_p = np.tile(d_b, (reps, 1))[keep]
    db = load_dbc(load_profile(PROFILE).dbc_path())
    used = {0xAA, 0x24, 0x25, 0xB4}
    others = [m.frame_id for m in db.messages if m.length == 8 and m.frame_id not in used]
    others = np.array(others[:45], dtype=np.int64)
    rates = rng.dirichlet(np.ones(others.size)) * FILLER_HZ
    t_f, id_f = [], []
    for frame_id, hz in zip(others, rates, strict=True):
        period = 1.0 / hz
        times = rng.uniform(0, period) + np.arange(0.0, seconds - period, period)
        t_f.append(times + rng.normal(0.0, 2e-5, times.size))
        id_f.append(np.full(times.size, frame_id))
    t_f, id_f = np.concatenate(t_f), np.concatenate(id_f)
    d_f = rng.integers(0, 256, size=(t_f.size, 8), dtype=np.uint8)
    t = np.concatenate([t_p, np.clip(t_f, 0.0, seconds)])
    order = np.argsort(t, kind="stable")
    return (
        EPOCH_S + t[order],
        np.concatenate([id_p, id_f])[order],
        np.concatenate([d_p, d_f])[order],
    )


_HEXCHARS = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)


def _write_candump(path: Path, bus, chunk: int = 1_000_000) -> None:
    """candump -L lines ``(SSSSSSSSSS.UUUUUU) can0 III#DDDDDDDDDDDDDDDD`` written with NumPy."""
    t, ids, data = bus
    with open(path, "wb") as fh:
        for start in range(0, t.size, chunk):
            sl = slice(start, start + chunk)
            us = np.round(t[sl] * 1e6).astype(np.int64)
            n = us.size
            line = np.empty((n, 46), dtype=np.uint8)
            line[:, 0] = ord("(")
            digits = us.copy()
            for col in range(17, 0, -1):  # 10 integer digits, ".", 6 fraction digits
                if col == 11:
                    line[:, col] = ord(".")
                    continue
                line[:, col] = 48 + digits % 10
                digits //= 10
            line[:, 18:25] = np.frombuffer(b") can0 ", dtype=np.uint8)
            for k in range(3):
                line[:, 25 + k] = _HEXCHARS[(ids[sl] >> (4 * (2 - k))) & 0xF]
            line[:, 28] = ord("#")
            d = data[sl]
            line[:, 29:45:2] = _HEXCHARS[d >> 4]
            line[:, 30:46:2] = _HEXCHARS[d & 0xF]
            line[:, 45] = ord("\n")
            line.tofile(fh)


def _write_python_can(path: Path, bus, chunk: int = 200_000) -> None:
    import can

    t, ids, data = bus
    with can.Logger(str(path)) as writer:
        for start in range(0, t.size, chunk):
            raw = data[start : start + chunk].tobytes()
            for k in range(min(chunk, t.size - start)):
                writer.on_message_received(
                    can.Message(
                        timestamp=float(t[start + k]),
                        arbitration_id=int(ids[start + k]),
                        is_extended_id=False,
                        data=raw[8 * k : 8 * k + 8],
                        channel=0,
                    )
                )


def _head(path: Path, out: Path, seconds: float) -> None:
    """The first ``seconds`` of a candump log."""
    limit = f"({EPOCH_S + seconds:.6f})".encode()
    with open(path, "rb") as src, open(out, "wb") as dst:
        for line in src:
            if line[: len(limit)] >= limit:
                break
            dst.write(line)


def _measure(code: str, path: Path, repeats: int = 1) -> dict:
    """The fastest of ``repeats`` fresh-process runs (others' load only ever slows a run down)."""
    runs = []
    for _ in range(repeats):
        out = subprocess.run(
            [sys.executable, "-c", code, str(path), PROFILE], capture_output=True, text=True
        )
        if out.returncode != 0:
            raise RuntimeError(f"measurement of {path.name} failed:\n{out.stderr}")
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    best = min(runs, key=lambda r: r["total_s"])
    best["repeats_total_s"] = [r["total_s"] for r in runs]
    best["repeats_cpu_s"] = [r["cpu_s"] for r in runs]
    return best


def _report(label: str, r: dict) -> None:
    print(
        f"{label:<34} {r['frames_read']:>9} frames  {r['total_s']:7.2f} s "
        f"(cpu {r['cpu_s']:.2f} s)  {r.get('s_per_hour', float('nan')):7.2f} s/h  "
        f"peak {r['peak_rss_mb']:.0f} MB",
        flush=True,
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="15 minutes of bus only")
    args = parser.parse_args()
    load_at_start = os.getloadavg()[0]
    t0 = time.perf_counter()
    block = _profile_block()
    print(f"profile block encoded by cantools in {time.perf_counter() - t0:.1f} s", flush=True)
    lengths_h = [0.25] if args.quick else [0.25, 0.5, 1.0]
    runs: list[dict] = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        hour = _bus(3600.0 * max(lengths_h), block)
        for hours in lengths_h:
            keep = hour[0] < EPOCH_S + 3600.0 * hours
            bus = tuple(a[keep] for a in hour)
            path = tmp / f"bus_{hours}h.log"
            t0 = time.perf_counter()
            _write_candump(path, bus)
            write_s = time.perf_counter() - t0
            r = _measure(_CHILD, path, repeats=REPEATS)
            r |= {
                "format": "candump",
                "reader": "tyrebayes NumPy candump parser + vectorised DBC decode",
                "hours": hours,
                "measured_hours": hours,
                "file_mb": path.stat().st_size / 2**20,
                "write_s": write_s,
                "s_per_hour": r["total_s"] / hours,
                "frames_per_s_of_log": r["frames_read"] / (3600.0 * hours),
            }
            runs.append(r)
            _report(f"candump {hours} h", r)
        longest = max(lengths_h)
        full = tmp / f"bus_{longest}h.log"
        # The per-frame path on a slice, scaled.
        slice_path = tmp / "slice.log"
        _head(full, slice_path, min(SLOW_SLICE_S, 3600.0 * longest))
        slice_h = min(SLOW_SLICE_S, 3600.0 * longest) / 3600.0
        slow = _measure(_SLOW_CHILD, slice_path, repeats=REPEATS)
        slow |= {
            "format": "candump",
            "reader": "python-can CanutilsLogReader + cantools Message.decode per frame",
            "hours": longest,
            "measured_hours": slice_h,
            "s_per_hour": slow["total_s"] / slice_h,
            "scaled": f"measured on the first {slice_h * 60:.0f} min, s_per_hour scaled to 1 h",
        }
        runs.append(slow)
        _report(f"candump per-frame ({slice_h * 60:.0f} min)", slow)
        for fmt in ("blf", "asc"):
            seconds = 3600.0 * longest if fmt == "blf" else min(ASC_SLICE_S, 3600.0 * longest)
            keep = hour[0] < EPOCH_S + seconds
            bus = tuple(a[keep] for a in hour)
            path = tmp / f"bus.{fmt}"
            t0 = time.perf_counter()
            _write_python_can(path, bus)
            write_s = time.perf_counter() - t0
            r = _measure(_CHILD, path)
            r |= {
                "format": fmt,
                "reader": f"python-can {fmt.upper()}Reader + vectorised DBC decode",
                "hours": longest,
                "measured_hours": seconds / 3600.0,
                "file_mb": path.stat().st_size / 2**20,
                "write_s": write_s,
                "s_per_hour": r["total_s"] / (seconds / 3600.0),
            }
            if seconds < 3600.0 * longest:
                r["scaled"] = f"measured on the first {seconds / 60:.0f} min, scaled to 1 h"
            runs.append(r)
            _report(f"{fmt} ({seconds / 60:.0f} min)", r)
            path.unlink()
    fast = [r for r in runs if r["format"] == "candump" and "NumPy" in r["reader"]]
    top = max(fast, key=lambda r: r["hours"])
    speedup_cpu = (slow["cpu_s"] / slow["measured_hours"]) / (top["cpu_s"] / top["measured_hours"])
    summary = {
        "target_s_per_hour_candump": TARGET_S_PER_HOUR,
        "target_peak_mb": TARGET_MB,
        "target_speedup_vs_per_frame": TARGET_SPEEDUP,
        "bus": {
            "profile": PROFILE,
            "profile_frames_per_s": sum(PROFILE_HZ.values()),
            "filler_frames_per_s": FILLER_HZ,
            "payload_bytes": 8,
        },
        "candump_s_per_hour": top["s_per_hour"],
        "candump_peak_rss_mb": top["peak_rss_mb"],
        "candump_peak_over_baseline_mb": top["peak_over_baseline_mb"],
        "meets_time_target": top["s_per_hour"] <= TARGET_S_PER_HOUR,
        "meets_memory_target": top["peak_rss_mb"] <= TARGET_MB,
        "speedup_vs_per_frame_wall": slow["s_per_hour"] / top["s_per_hour"],
        # CPU time is not inflated by the other processes on a shared machine; wall time is.
        "speedup_vs_per_frame_cpu": speedup_cpu,
        "meets_speedup_target": speedup_cpu >= TARGET_SPEEDUP,
        "s_per_hour_by_length": {str(r["hours"]): r["s_per_hour"] for r in fast},
        # Linearity in CPU time: the wall time of one run also holds others' load.
        "cpu_s_per_hour_by_length": {
            str(r["hours"]): r["cpu_s"] / r["measured_hours"] for r in fast
        },
        "candump_cpu_s_per_hour": top["cpu_s"] / top["measured_hours"],
        "blf_s_per_hour": next(r["s_per_hour"] for r in runs if r["format"] == "blf"),
        "asc_s_per_hour": next(r["s_per_hour"] for r in runs if r["format"] == "asc"),
        "cpu_count": os.cpu_count(),
        "load_average_1min_at_start": load_at_start,
        "note": (
            "shared 2-core machine (other agents running); each measurement in a fresh "
            "single-threaded process, candump and per-frame runs the fastest of 3, BLF and ASC one "
            "run; total_s is wall clock after the imports, cpu_s "
            "the process CPU time; peak_rss_mb is the peak resident set of the whole process "
            "(VmHWM, imports included), peak_over_baseline_mb what the log and the pipeline "
            "add; ru_maxrss_mb (getrusage) is carried over from the forking parent on Linux "
            "and over-states"
        ),
        "runs": runs,
    }
    if len(fast) > 1:
        summary["ratio_s_per_hour_longest_over_shortest"] = (
            top["s_per_hour"] / min(fast, key=lambda r: r["hours"])["s_per_hour"]
        )
    print(json.dumps({k: v for k, v in summary.items() if k != "runs"}, indent=1))
    print(f"saved {write_result('can_speed', summary, quick=args.quick)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
