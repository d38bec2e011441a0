"""A new process's first tyre fit, with and without the traced programs kept on disk.

JAX's compilation cache spares a new process (a fleet worker, every ``tyrebayes fit-tyre``) the
compilation of a fit, not its tracing; ``tyrebayes.internal.stored_program`` keeps the traced
program too, and the layout's initial medians are kept beside it. Each measurement is a fresh
single-threaded process fitting the same windows (a simulated one-hour drive, fast path, the
default model) twice: the first fit (tracing or reading the programs, loading the compiled
ones) and the second (steady state). Three processes in a row on one cache folder:

1. ``cold``: an empty cache (compiles everything, keeps the programs);
2. ``compiled_only``: the compiled programs kept, the traced ones and the medians removed (what
   a new process paid before they were kept);
3. ``stored``: everything kept.

The machine is shared: the load averages are recorded, and 2 and 3 run back to back, ``--repeats``
times each (fastest kept).

Usage: ``python benchmarks/stored_program.py [--repeats N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from _results import write_result  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "stored_program.json"

_CHILD = r"""
import json, sys, time
import numpy as np
from benchmarks._internal import configure_jax
configure_jax(sys.argv[1])
from tyrebayes import WindowTable, fit_tyre, stack_drives
windows = WindowTable.from_dict(dict(np.load(sys.argv[2])))
obs = stack_drives([windows], ["dry"], pad_to=int(sys.argv[3]))
times = []
for _ in range(2):
    start = time.perf_counter()
    fit = fit_tyre(obs, method="fast")
    times.append(time.perf_counter() - start)
print(json.dumps({"first_fit_s": times[0], "second_fit_s": times[1],
                  "c_x_mean": float(np.mean(fit.idata["posterior"]["c_x"].values)),
                  "converged": bool(fit.diagnostics.converged)}))
"""


def _windows(path: Path) -> int:
    """A simulated one-hour drive's windows saved at ``path``; returns the padded length."""
    import numpy as np
    from _internal import pad_size

    from tyrebayes import (
        compute_features,
        load_vehicle,
        observations_from_features,
        validate_stream,
    )
    from tyrebayes.simulate import simulate_drive

    vehicle = load_vehicle("compact_fwd")
    df, _ = simulate_drive(3, vehicle, "all_season", duration_s=3600.0)
    windows = observations_from_features(compute_features(validate_stream(df, vehicle), vehicle))
    np.savez(path, **windows.to_dict())
    return pad_size(len(windows))


def _run(cache: Path, windows: Path, pad: int) -> dict:
    env = {
        **os.environ,
        "OMP_NUM_THREADS": "1",
        "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false",
    }
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(cache), str(windows), str(pad)],
        capture_output=True,
        text=True,
        env=env,
        cwd=Path(__file__).resolve().parents[1],  # the child imports benchmarks._internal
        check=True,
    )
    return {**json.loads(out.stdout.strip().splitlines()[-1]), "load_average": os.getloadavg()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        windows, cache = tmp / "windows.npz", tmp / "cache"
        pad = _windows(windows)
        runs = {"cold": _run(cache, windows, pad)}
        compiled_only, stored = [], []
        for _ in range(args.repeats):
            shutil.rmtree(cache / "tyrebayes-programs", ignore_errors=True)
            shutil.rmtree(cache / "tyrebayes-layouts", ignore_errors=True)
            compiled_only.append(_run(cache, windows, pad))
            stored.append(_run(cache, windows, pad))
        runs["compiled_only"] = min(compiled_only, key=lambda r: r["first_fit_s"])
        runs["stored"] = min(stored, key=lambda r: r["first_fit_s"])
    same = {r["c_x_mean"] for r in runs.values()}
    result = {
        "benchmark": "stored_program",
        "windows_padded": pad,
        "repeats": args.repeats,
        "runs": runs,
        "first_fit_saving_s": runs["compiled_only"]["first_fit_s"] - runs["stored"]["first_fit_s"],
        "same_c_x_in_every_run": len(same) == 1,
        "note": "shared 2-core machine: wall seconds of one single-threaded process per run; "
        "load averages recorded",
        "cpu_count": os.cpu_count(),
    }
    write_result("stored_program", result, path=RESULTS)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
