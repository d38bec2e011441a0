"""XLA:CPU's two code generators on a tyre fit: compile seconds against run seconds.

XLA:CPU emits fused loops through its MLIR fusion emitters by default; with
``--xla_cpu_use_fusion_emitters=false`` it uses its older LLVM IR emitters, which compile
faster. Which generator's code runs faster depends on the program, so the steady-state fit is
timed too. Compilation is what the test suite pays for: it compiles a program for nearly every
test and runs it once (``tests/conftest.py`` turns the fusion emitters off for that reason; this
benchmark is the measurement behind it). The package itself runs on the default, on which its
speed benchmarks were measured.

Each measurement is a fresh single-threaded process without a persistent compilation cache,
fitting the same windows (a simulated one-hour drive, fast path, the default model) twice: the
first fit compiles its programs, the second is the steady state. The seconds XLA spent
compiling are read from JAX's monitoring events. Both settings fit the same windows, so their
posteriors are compared too (they differ by round-off only if the generators agree).

Usage: ``python benchmarks/compile_backend.py [--repeats N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

from _results import write_result  # noqa: E402
from _revisions import run_child
from stored_program import _windows

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "compile_backend.json"

SINGLE_THREAD = "--xla_cpu_multi_thread_eigen=false"
SETTINGS = {
    "fusion_emitters": "",
    "llvm_ir_emitters": "--xla_cpu_use_fusion_emitters=false",
}

_CHILD = r"""
import collections, json, sys, time
import numpy as np
import jax
from jax import monitoring
seconds = collections.Counter()
monitoring.register_event_duration_secs_listener(
    lambda name, duration, **_: seconds.update({name: duration}))
jax.config.update("jax_enable_x64", True)
from tyrebayes import WindowTable, fit_tyre, stack_drives
windows = WindowTable.from_dict(dict(np.load(sys.argv[1])))
obs = stack_drives([windows], ["dry"], pad_to=int(sys.argv[2]))
times, compile_s = [], []
for _ in range(2):
    start = time.perf_counter()
    fit = fit_tyre(obs, method="fast")
    times.append(time.perf_counter() - start)
    compile_s.append(seconds["/jax/core/compile/backend_compile_duration"])
summary = fit.summary()
print(json.dumps({
    "first_fit_s": times[0], "second_fit_s": times[1],
    "backend_compile_s": compile_s[0],
    "backend_compile_in_second_fit_s": compile_s[1] - compile_s[0],
    "c_x_mean": summary["c_x"]["mean"], "c_x_sd": summary["c_x"]["sd"],
    "mu_max_mean": summary["mu_max"]["mean"], "converged": bool(fit.diagnostics.converged)}))
"""


def _run(flags: str, windows: Path, pad: int) -> dict:
    env = {"OMP_NUM_THREADS": "1", "XLA_FLAGS": f"{SINGLE_THREAD} {flags}".strip()}
    return {**run_child(_CHILD, [windows, pad], None, env), "load_average": os.getloadavg()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        windows = Path(tmp) / "windows.npz"
        pad = _windows(windows)
        runs = {name: [] for name in SETTINGS}
        for _ in range(args.repeats):  # interleaved: a change in the machine's load hits both
            for name, flags in SETTINGS.items():
                runs[name].append(_run(flags, windows, pad))
    best = {name: min(r, key=lambda x: x["first_fit_s"]) for name, r in runs.items()}
    fusion, llvm = best["fusion_emitters"], best["llvm_ir_emitters"]
    result = {
        "benchmark": "compile_backend",
        "windows_padded": pad,
        "repeats": args.repeats,
        "settings": SETTINGS,
        "runs": runs,
        "fastest_first_fit": best,
        "compile_ratio_llvm_to_fusion": llvm["backend_compile_s"] / fusion["backend_compile_s"],
        "steady_fit_ratio_llvm_to_fusion": llvm["second_fit_s"] / fusion["second_fit_s"],
        "c_x_mean_relative_difference": abs(llvm["c_x_mean"] / fusion["c_x_mean"] - 1.0),
        "c_x_sd_relative_difference": abs(llvm["c_x_sd"] / fusion["c_x_sd"] - 1.0),
        "note": "shared 2-core machine: wall seconds of one single-threaded process per run, "
        "settings interleaved, the fastest first fit of each kept; load averages recorded",
        "cpu_count": os.cpu_count(),
    }
    write_result("compile_backend", result, path=RESULTS)
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
