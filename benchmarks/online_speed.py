"""Speed of the online estimator: one car-hour of windows on one core, and many cars vmapped.

One simulated one-hour drive (compact_fwd, Magic Formula truth) through the stream pipeline
gives the windows (steps of 30 s, padded to 121 windows). Timed after compilation, median of
``--reps`` runs, on one core: the process is pinned to one CPU before JAX starts
(``os.sched_setaffinity``), so XLA's CPU client sizes its thread pool to it. XLA_FLAGS alone do
not do that: with them two threads still share the work.

* one car-hour per tyre-curve model (target ≤ 40 ms, i.e. ≥ 10^5× real time), in the default 30 s
  clock steps and with sparse driving packed into steps of up to ``PACKED_STEP_S``
  (``window_blocks``' ``max_step_s``: fewer, fuller steps; ``online_change.py --max-step-s``
  measures what it costs the alarms);
* where a Magic Formula car-hour's time goes: the block log-likelihood's Gauss-Newton pass (the
  filter's curvature), its exact Hessian for comparison, its value and gradient, and its value
  alone, each timed over the hour's steps, and how many curvatures the
  filter took (counted in a separate, untimed run);
* the Magic Formula car-hour compiled with XLA's default options beside the estimator's own
  (``COMPILER_OPTIONS``), alternated ``--before-pairs`` times, and how far their results differ;
* ``--cars`` copies of that car-hour vmapped in one call, the time per car-hour;
* ``--fleet-cars`` (10^4, the issue's number) cars in one compiled call over the first
  ``--fleet-steps`` steps of the drive (each car's own copy of the windows; one hour each would
  take about as many minutes on one core as the per-car-hour time in ms): ``lax.map`` over
  chunks of ``--chunk`` cars, each chunk vmapped (one plain vmap over 100 cars of an hour hung
  in XLA's CPU runtime, jaxlib 0.10.2; chunks of 24-30 did not), in a child process with a time
  limit: the time per car-hour, or that it gave no result.

Under vmap a ``lax.cond`` computes both branches, so the Laplace update's skipped curvatures and
line searches are computed for every car: on one CPU core a vmapped car-hour costs more than a
single car's.

With ``--before REV``, the Magic Formula car-hour (30 s steps) of the package as of git
revision REV beside this checkout's: each in a fresh child process pinned to the same core, on
the same simulated hour (each side simulates it with its own revision's package and benchmark
helpers), alternating ``--before-pairs`` times, so that both see the machine as
it was then (a shared machine's speed drifts by more than a change's gain between runs).

Timings include whatever else ran on the machine (the load average is recorded in the JSON).

Usage: ``python benchmarks/online_speed.py [--reps N] [--cars N] [--before REV] [--no-fleet]``
(``--no-fleet`` skips the 10^4-car call, about 10-25 minutes on this machine; the JSON then
says it was not run).
"""

from __future__ import annotations

import os

from _results import write_result  # noqa: E402

os.environ["XLA_FLAGS"] = os.environ.get("XLA_FLAGS", "") + " --xla_cpu_multi_thread_eigen=false"
# One core (module docstring): the last CPU this process may run on.
CORE = max(os.sched_getaffinity(0))
os.sched_setaffinity(0, {CORE})

import argparse  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from _internal import block_curvature, block_log_likelihood  # noqa: E402
from _internal import laplace_update as laplace_module  # noqa: E402
from _online_common import machine, simulated_windows  # noqa: E402
from _revisions import package_at, run_child  # noqa: E402

from tyrebayes.inference.online import (  # noqa: E402
    COMPILER_OPTIONS,
    PACKED_STEP_S,
    STEP_S,
    OnlineEstimator,
    run_online,
    run_online_cars,
    stream_steps,
)

RESULTS = Path(__file__).parent / "results" / "online_speed.json"
KINDS = ("magic", "shaped", "brush", "linear")

# One Magic Formula car-hour in 30 s steps, timed in a child on the package it is given
# (argv: core, benchmarks folder, repetitions); prints its JSON on the last line.
_CAR_HOUR_CHILD = r"""
import os, sys
os.environ["XLA_FLAGS"] = os.environ.get("XLA_FLAGS", "") + " --xla_cpu_multi_thread_eigen=false"
os.sched_setaffinity(0, {int(sys.argv[1])})
sys.path.insert(0, sys.argv[2])
import json, time
import jax
jax.config.update("jax_enable_x64", True)
import numpy as np
from _online_common import simulated_windows
from tyrebayes.inference.online import OnlineEstimator, run_online, stream_steps
windows, _, _ = simulated_windows(0, 3600.0)
steps = stream_steps(windows)
est = OnlineEstimator.create(model="magic")
jax.block_until_ready(run_online(est, est.init(), steps))
walls = []
for _ in range(int(sys.argv[3])):
    t0 = time.perf_counter()
    jax.block_until_ready(run_online(est, est.init(), steps))
    walls.append(time.perf_counter() - t0)
hours = float(steps.time_s[-1]) / 3600.0
print(json.dumps({"car_hour_s": float(np.median(walls)) / hours, "steps": steps.n_blocks}))
"""


def timed(fn, reps):
    """(compile and first run, median of ``reps`` runs after it, fastest of them) [s]."""
    t0 = time.perf_counter()
    jax.block_until_ready(fn())
    first = time.perf_counter() - t0
    walls = []
    for _ in range(reps):
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        walls.append(time.perf_counter() - t0)
    return first, float(np.median(walls)), float(np.min(walls))


def where_the_time_goes(steps, reps) -> dict:
    """The Magic Formula block log-likelihood's passes, each scanned over the hour's steps at the
    type prior's mean (per step, ms), and the curvatures one car-hour takes."""
    est = OnlineEstimator.create(model="magic")
    theta = est.prior.mean
    weight = jnp.asarray(0.5)

    def scanned(make):
        # θ and the slip weight are arguments, as in the filter: closed over as constants,
        # XLA would fold the parts of the pass that depend on them alone.
        def over(blocks, theta, weight):
            def one(carry, block):
                return carry, make(block, weight)(theta)

            return jax.lax.scan(one, 0.0, blocks)[1]

        fn = jax.jit(over)
        return timed(lambda: fn(steps, theta, weight), reps)[1] / steps.n_blocks * 1e3

    def nll(block, weight):
        return lambda t: -block_log_likelihood(t, block, weight, "magic", est.priors)

    passes = {
        "gauss_newton_ms": scanned(
            lambda block, weight: lambda t: block_curvature(t, block, weight, "magic", est.priors)
        ),
        "exact_hessian_ms": scanned(lambda block, weight: jax.jacfwd(jax.grad(nll(block, weight)))),
        "value_and_gradient_ms": scanned(
            lambda block, weight: jax.value_and_grad(nll(block, weight))
        ),
        "value_ms": scanned(nll),
    }
    # Curvatures counted in an untimed run: a host callback at each of the update's
    # eigendecompositions of one (laplace_update._informations, once per curvature taken).
    counted = []
    informations = laplace_module._informations

    def counting(curvature):
        jax.debug.callback(lambda: counted.append(1))
        return informations(curvature)

    laplace_module._informations = counting
    try:
        probe = OnlineEstimator.create(model="magic", config=est.config)
        jax.block_until_ready(jax.jit(lambda s, b: probe.run(s, b))(probe.init(), steps))
    finally:
        laplace_module._informations = informations
    return {
        "kind": "magic",
        "curvature": "gauss_newton" if est.config.gauss_newton else "exact_hessian",
        "per_step": passes,
        "curvatures_per_car_hour": len(counted),
        "steps_per_car_hour": steps.n_blocks,
        "curvature_share_of_car_hour_estimate": None,  # filled by main with the car-hour time
        "note": "each pass timed alone over the hour's steps at the type prior mean, passed as an "
        "argument (jit, scan); the filter takes the gauss_newton pass (block_curvature)",
    }


def fleet_call(args, steps) -> dict:
    """``--fleet-cars`` cars × the first ``--fleet-steps`` steps in one call (chunks vmapped)."""
    est = OnlineEstimator.create(model="magic")
    head = jax.tree.map(lambda x: x[: args.fleet_steps], steps)
    fleet_hours = float(head.time_s[-1]) / 3600.0
    cars = jax.tree.map(lambda x: jnp.array(np.broadcast_to(x, (args.fleet_cars, *x.shape))), head)
    init = est.init()
    fn = eqx.filter_jit(
        lambda cars: jax.lax.map(lambda b: est.run(init, b), cars, batch_size=args.chunk),
        compiler_options=COMPILER_OPTIONS,
    )
    first, wall, _ = timed(lambda: fn(cars), 1)
    return {
        "kind": "magic",
        "n_cars": args.fleet_cars,
        "cars_per_vmapped_chunk": args.chunk,
        "steps_per_car": args.fleet_steps,
        "hours_per_car": fleet_hours,
        "compile_and_first_run_s": first,
        "wall_s": wall,
        "per_car_hour_s": wall / (args.fleet_cars * fleet_hours),
        "target_cars": 10_000,
        "target_met": bool(args.fleet_cars >= 10_000),
        "note": "one compiled call: lax.map over chunks, each chunk vmapped (module docstring)",
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }


def fleet_in_child(args) -> dict:
    """:func:`fleet_call` in a child process with a time limit: one call over 100 cars of a
    full hour hung in XLA's CPU runtime (jaxlib 0.10.2, every thread idle), and a hang must
    not cost the other figures."""
    command = [
        sys.executable,
        __file__,
        "--fleet-only",
        f"--fleet-cars={args.fleet_cars}",
        f"--fleet-steps={args.fleet_steps}",
        f"--chunk={args.chunk}",
    ]
    try:
        done = subprocess.run(
            command, capture_output=True, text=True, timeout=args.fleet_timeout, check=True
        )
    except subprocess.TimeoutExpired:
        return {
            "n_cars": args.fleet_cars,
            "steps_per_car": args.fleet_steps,
            "target_cars": 10_000,
            "target_met": False,
            "failed": f"no result within {args.fleet_timeout} s (killed)",
        }
    except subprocess.CalledProcessError as error:
        return {
            "n_cars": args.fleet_cars,
            "target_cars": 10_000,
            "target_met": False,
            "failed": error.stderr.strip().splitlines()[-1],
        }
    return json.loads(done.stdout.strip().splitlines()[-1])


def _alternated(runs: dict, first: str, second: str) -> dict:
    """Two alternated Magic Formula car-hour timings (30 s steps): each side's runs and median,
    and the speedup of ``second`` over ``first``."""
    median = {side: float(np.median(runs[side])) for side in (first, second)}
    return {
        "kind": "magic",
        "max_step_s": STEP_S,
        **{f"car_hour_s_{side}": runs[side] for side in (first, second)},
        **{f"car_hour_s_{side}_median": median[side] for side in (first, second)},
        "speedup": median[first] / median[second],
    }


def _same(outputs: dict, field: str) -> bool:
    """Whether the runs' trajectories have the same ``field`` at every step."""
    first, second = (np.asarray(getattr(run.trajectory, field)) for run in outputs.values())
    return bool(np.array_equal(first, second))


def compiler_options_gain(steps, hours: float, pairs: int, reps: int) -> dict:
    """The Magic Formula car-hour (30 s steps) compiled with XLA's default options and with the
    estimator's :data:`~tyrebayes.inference.online.COMPILER_OPTIONS`, alternated ``pairs`` times
    in this process, and how far their results differ."""
    est = OnlineEstimator.create(model="magic")
    default = eqx.filter_jit(lambda est, state, blocks: est.run(state, blocks))
    runs = {"default": [], "estimator": []}
    outputs = {}
    for _ in range(pairs):
        for side, fn in (("default", default), ("estimator", run_online)):
            outputs[side] = jax.block_until_ready(fn(est, est.init(), steps))
            runs[side].append(timed(lambda fn=fn: fn(est, est.init(), steps), reps)[1] / hours)
    final = {side: outputs[side].state for side in outputs}
    sd = np.sqrt(np.diag(np.asarray(final["default"].cov)))
    mean_sds = np.abs(np.asarray(final["estimator"].mean - final["default"].mean)) / sd
    c_x = {side: np.asarray(outputs[side].trajectory.c_x.mean) for side in outputs}
    return {
        **_alternated(runs, "default", "estimator"),
        "options": COMPILER_OPTIONS,
        "pairs": pairs,
        "final_mean_max_diff_posterior_sds": float(np.max(mean_sds)),
        "c_x_trajectory_max_rel_diff": float(
            np.max(np.abs(c_x["estimator"] - c_x["default"]) / c_x["default"])
        ),
        "same_alarms": _same(outputs, "alarm"),
        "same_ready_flags": _same(outputs, "ready"),
        "note": "each value the median of reps runs after compilation; the two alternate on one "
        "core",
    }


def before_and_after(revision: str, pairs: int, reps: int) -> dict:
    """The Magic Formula car-hour at ``revision`` and on this checkout, alternated ``pairs``
    times in fresh children on this core (module docstring)."""
    with tempfile.TemporaryDirectory() as tmp:
        # The before side's drives come from that revision's helpers, which import the package
        # as it was then.
        code = package_at(revision, Path(tmp) / "before", ("tyrebayes", "models", "benchmarks"))
        helpers = {"before": code / "benchmarks", "after": Path(__file__).parent}
        runs = {"before": [], "after": []}
        for _ in range(pairs):
            for side, where in (("before", code), ("after", None)):
                child = run_child(_CAR_HOUR_CHILD, [CORE, helpers[side], reps], where, {})
                runs[side].append(child["car_hour_s"])
    return {
        **_alternated(runs, "before", "after"),
        "before_revision": revision,
        "pairs": pairs,
        "note": "each value the median of its child's runs; children alternate on one core",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5)
    # 24 cars a call: one call over 100 cars of an hour hung (fleet_in_child).
    parser.add_argument("--cars", type=int, default=24)
    parser.add_argument("--fleet-cars", type=int, default=10_000)
    parser.add_argument("--fleet-steps", type=int, default=6)
    parser.add_argument("--chunk", type=int, default=25)
    parser.add_argument("--fleet-timeout", type=float, default=1200.0)
    parser.add_argument("--fleet-only", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--no-fleet", action="store_true", help="skip the --fleet-cars call")
    parser.add_argument("--before", help="git revision whose car-hour to time beside this one")
    parser.add_argument("--before-pairs", type=int, default=3)
    parser.add_argument("--out", default=str(RESULTS))
    args = parser.parse_args()
    load_at_start = os.getloadavg()[0]
    windows, _, _ = simulated_windows(0, 3600.0)
    steps = stream_steps(windows)
    if args.fleet_only:
        print(json.dumps(fleet_call(args, steps)), flush=True)
        return
    hours = float(steps.time_s[-1] - 0.0) / 3600.0
    rows = []
    packed = stream_steps(windows, max_step_s=PACKED_STEP_S)
    for kind in KINDS:
        est = OnlineEstimator.create(model=kind)
        for max_step_s, these in ((STEP_S, steps), (PACKED_STEP_S, packed)):
            first, wall, fastest = timed(
                lambda est=est, these=these: run_online(est, est.init(), these), args.reps
            )
            rows.append(
                {
                    "kind": kind,
                    "max_step_s": max_step_s,
                    "steps_per_car_hour": these.n_blocks / hours,
                    "compile_and_first_run_s": first,
                    "car_hour_s": wall / hours,
                    "car_hour_fastest_s": fastest / hours,
                    "target_s": 0.040,
                    "target_met": bool(wall / hours <= 0.040),
                    "real_time_factor": 3600.0 / (wall / hours),
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    profile = where_the_time_goes(steps, args.reps)
    magic_s = (
        next(r["car_hour_s"] for r in rows if r["kind"] == "magic" and r["max_step_s"] == STEP_S)
        * hours
    )
    profile["curvature_share_of_car_hour_estimate"] = (
        profile["curvatures_per_car_hour"] * profile["per_step"]["gauss_newton_ms"] * 1e-3 / magic_s
    )
    print(json.dumps(profile), flush=True)
    options = compiler_options_gain(steps, hours, args.before_pairs, args.reps)
    print(json.dumps(options), flush=True)
    vmapped = []
    for kind, max_step_s, these in (
        ("magic", STEP_S, steps),
        ("magic", PACKED_STEP_S, packed),
        ("linear", STEP_S, steps),
    ):
        est = OnlineEstimator.create(model=kind)
        cars = jax.tree.map(lambda x: jnp.broadcast_to(x, (args.cars, *x.shape)), these)
        states = jax.tree.map(lambda x: jnp.broadcast_to(x, (args.cars, *x.shape)), est.init())
        first, wall, _ = timed(
            lambda est=est, cars=cars, states=states: run_online_cars(est, states, cars), 1
        )
        vmapped.append(
            {
                "kind": kind,
                "max_step_s": max_step_s,
                "n_cars": args.cars,
                "compile_and_first_run_s": first,
                "wall_s": wall,
                "per_car_hour_s": wall / (args.cars * hours),
                "hours_per_car": hours,
            }
        )
        print(json.dumps(vmapped[-1]), flush=True)
    fleet = (
        {"not_run": "--no-fleet: see the previous JSON (module docstring)"}
        if args.no_fleet
        else fleet_in_child(args)
    )
    print(json.dumps(fleet), flush=True)
    compared = before_and_after(args.before, args.before_pairs, args.reps) if args.before else None
    if compared:
        print(json.dumps(compared), flush=True)
    result = {
        "benchmark": "online_speed",
        "windows_per_car_hour": int(np.sum(np.asarray(steps.mask)) / hours),
        "steps_per_car_hour": steps.n_blocks / hours,
        "step_width": int(steps.slip.shape[1]),
        "hours_per_run": hours,
        "threads": f"one core: process pinned to CPU {CORE} (os.sched_setaffinity) before JAX "
        "started; the vmapped and fleet calls too",
        "single_car": rows,
        "where_the_time_goes": profile,
        "compiler_options": options,
        "vmapped": vmapped,
        "vmapped_fleet": fleet,
        "before_and_after": compared,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "machine": {**machine(), "load_average_1min_at_start": load_at_start},
    }
    write_result("online_speed", result, path=args.out)


if __name__ == "__main__":
    main()
