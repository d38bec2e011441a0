"""Throughput of the brush model and its gradient against the memory-bound floor (issue 2).

Over 10⁷ slips, in one process and one run, it times:

* ``copy``: a jitted ``jnp.copy`` of the slip array — reads one array, writes one: the floor a
  memory-bound elementwise kernel cannot beat;
* ``force``: ρ_x(σ) of :func:`tyrebayes.physics.tyre.brush_longitudinal` (with the sliding-friction
  extension, the slowest branch set);
* ``force_and_slope``: ρ_x and ∂ρ_x/∂σ per slip (``jax.jvp`` with a unit tangent: one
  forward-mode pass, the derivative an inverse or a Newton step needs) — reads one array, writes
  two;
* ``force_and_param_grad``: Σρ_x and its gradient with respect to (C_x, μ, r) by reverse mode
  (``jax.value_and_grad``), the shape of a likelihood gradient in the inference.

Throughput is elements (slips) per second from the best of ``--repeats`` calls after a warm-up
(compilation excluded; the machine is shared, so the best call is the least disturbed one); the
median and the process CPU time are recorded too. Target: force + gradient at ≥ 0.5× the copy's
elements per second.

Usage: ``python benchmarks/physics_speed.py [--n 10000000] [--repeats 7] [--x64]``.
Writes ``benchmarks/results/physics_speed.json`` (``physics_speed_x64.json`` with ``--x64``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import jax
from _results import write_result  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
TARGET_RATIO = 0.5


def _time(fn, args, repeats: int) -> dict[str, float]:
    jax.block_until_ready(fn(*args))  # compile and warm up
    walls, cpus = [], []
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        jax.block_until_ready(fn(*args))
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    return {
        "best_s": min(walls),
        "median_s": statistics.median(walls),
        "cpu_median_s": statistics.median(cpus),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10_000_000, help="number of slips")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--x64", action="store_true", help="float64 instead of float32")
    args = parser.parse_args(argv)
    if args.x64:
        jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp

    from tyrebayes.physics import brush_longitudinal

    c_x, mu, ratio = 30.0, 0.9, 0.8
    dtype = jnp.float64 if args.x64 else jnp.float32
    # Slips across adhesion, the peak (0.09) and sliding, both signs: every branch is exercised.
    slip = jax.random.uniform(jax.random.PRNGKey(0), (args.n,), dtype, -0.3, 0.3)
    params = jnp.array([c_x, mu, ratio], dtype)

    copy = jax.jit(jnp.copy)
    force = jax.jit(lambda s: brush_longitudinal(s, c_x, mu, ratio))

    @jax.jit
    def force_and_slope(s):
        return jax.jvp(lambda x: brush_longitudinal(x, c_x, mu, ratio), (s,), (jnp.ones_like(s),))

    @jax.jit
    def force_and_param_grad(p, s):
        return jax.value_and_grad(lambda q: jnp.sum(brush_longitudinal(s, q[0], q[1], q[2])))(p)

    # Correctness before speed: the forward-mode slope is the analytic one at a few points.
    rho, slope = force_and_slope(jnp.array([0.0, 0.05, 0.5], dtype))
    assert abs(float(slope[0]) - c_x) < 1e-3 * c_x, slope

    cases = {
        "copy": (copy, (slip,)),
        "force": (force, (slip,)),
        "force_and_slope": (force_and_slope, (slip,)),
        "force_and_param_grad": (force_and_param_grad, (params, slip)),
    }
    results = {}
    for name, (fn, fargs) in cases.items():
        r = _time(fn, fargs, args.repeats)
        r["elements_per_s"] = args.n / r["best_s"]
        r["elements_per_s_median"] = args.n / r["median_s"]
        results[name] = r
    floor = results["copy"]["elements_per_s"]
    for r in results.values():
        r["ratio_to_copy"] = r["elements_per_s"] / floor
        r["ratio_to_copy_median"] = (
            r["elements_per_s_median"] / results["copy"]["elements_per_s_median"]
        )
    summary = {
        "n_slips": args.n,
        "dtype": str(jnp.dtype(dtype)),
        "repeats": args.repeats,
        "target_ratio": TARGET_RATIO,
        "meets_target_force_and_slope": results["force_and_slope"]["ratio_to_copy"] >= TARGET_RATIO,
        "meets_target_force_and_param_grad": results["force_and_param_grad"]["ratio_to_copy"]
        >= TARGET_RATIO,
        "backend": jax.default_backend(),
        "jax_version": jax.__version__,
        "cpu_count": os.cpu_count(),
        "load_average_1min_at_start": os.getloadavg()[0],
        "note": (
            "shared 2-core machine (other agents running): throughput from the best of the "
            "repeated calls (compile excluded), medians and process CPU time recorded too"
        ),
        "results": results,
    }
    for name, r in results.items():
        print(
            f"{name:<22} best {r['best_s'] * 1e3:8.1f} ms  median {r['median_s'] * 1e3:8.1f} ms  "
            f"cpu {r['cpu_median_s'] * 1e3:8.1f} ms  {r['elements_per_s'] / 1e6:8.1f} M/s  "
            f"{r['ratio_to_copy']:.2f}x copy",
            flush=True,
        )
    print(
        f"target: force + gradient >= {TARGET_RATIO}x copy -> "
        f"slope {summary['meets_target_force_and_slope']}, "
        f"parameter gradient {summary['meets_target_force_and_param_grad']}"
    )
    out = RESULTS / ("physics_speed_x64.json" if args.x64 else "physics_speed.json")
    out = write_result("physics_speed", summary, path=out)
    print(f"saved {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
