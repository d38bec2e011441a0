"""Where the online filter's Magic Formula time goes: the cost of the block likelihood's curvature.

Issue 26 asks for one car-hour in ≤ 40 ms; with the exact Hessian of each step's block
log-likelihood most of the Magic Formula filter's time went into it (``where_the_time_goes`` of
``online_speed.json``), and the filter now takes the Gauss-Newton information in its place
(:func:`~tyrebayes.inference.online.block_likelihood.block_curvature`). This benchmark times,
on one step of a simulated one-hour drive (the step of most windows, padded as the filter pads
it), in one single-threaded process pinned to one core, interleaved so that the machine's load
falls on all alike:

* ``hessian``: the filter's pass: value, gradient and Hessian by forward-over-reverse
  (``laplace_update``'s first pass), and the other three orders of second derivatives;
* ``gradient`` and ``value``: one pass each;
* ``jacobian``: the forward Jacobian of the per-window quantities the likelihood is made of
  (``window_quantities``: slip mean and scale, force mean and scale, headroom below μ_max);
* ``gauss_newton``: the filter's pass now: value, gradient and Gauss-Newton information
  (``block_curvature``: that Jacobian, and the likelihood's Hessian in the quantities);

for the ``magic``, ``brush`` and ``linear`` models, with the compiled Hessian program's count of
multiplies on (directions × windows) arrays, the expression swell of differentiating the curve's
inverse twice. Each time is the fastest of ``--repeats`` calls (the least disturbed).

Usage: ``python benchmarks/online_curvature_cost.py [--repeats N] [--out FILE]``.
"""

from __future__ import annotations

import os

from _results import write_result  # noqa: E402

os.sched_setaffinity(0, {max(os.sched_getaffinity(0))})
os.environ["XLA_FLAGS"] = (
    "--xla_cpu_multi_thread_eigen=false " + os.environ.get("XLA_FLAGS", "")
).strip()

import argparse  # noqa: E402
import json  # noqa: E402
import re  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _internal import block_curvature, block_log_likelihood, model_sites  # noqa: E402
from _online_common import machine, simulated_windows  # noqa: E402

from tyrebayes import OnlineEstimator, stream_steps  # noqa: E402
from tyrebayes.inference import window_quantities  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "online_curvature_cost.json"
MODELS = ("magic", "brush", "linear")


def one_step(seed: int = 0):
    """The step with most windows of ``online_speed.py``'s simulated hour, as the filter pads it."""
    windows, _, _ = simulated_windows(seed, 3600.0)
    steps = stream_steps(windows)
    k = int(np.argmax(np.asarray(steps.mask).sum(axis=1)))
    step = jax.tree.map(lambda x: x[k] if hasattr(x, "ndim") and x.ndim > 0 else x, steps)
    return step, int(np.asarray(step.mask).sum())


def programs(model: str, block) -> tuple[dict, jax.Array, int]:
    estimator = OnlineEstimator.create(model=model)
    theta = estimator.init().mean
    priors, weight = estimator.priors, jnp.ones((), theta.dtype)
    basis = jnp.eye(theta.shape[0], dtype=theta.dtype)

    def nll(t):
        return -block_log_likelihood(t, block, weight, model, priors)

    def quantities(t):
        return window_quantities(model_sites(t, model, priors), block.observations(weight), model)

    value_and_gradient = jax.value_and_grad(nll)
    fns = {
        "hessian_fwd_over_rev": lambda t: jax.vmap(
            lambda e: jax.jvp(value_and_gradient, (t,), (e,)), out_axes=(None, 0)
        )(basis),
        "hessian_rev_over_fwd": jax.jacrev(jax.jacfwd(nll)),
        "hessian_fwd_over_fwd": jax.jacfwd(jax.jacfwd(nll)),
        "hessian_rev_over_rev": jax.jacrev(jax.jacrev(nll)),
        "gradient": value_and_gradient,
        "value": nll,
        "jacobian_of_window_quantities": lambda t: jax.vmap(
            lambda e: jax.jvp(quantities, (t,), (e,)), out_axes=(None, 0)
        )(basis),
        "gauss_newton": lambda t: block_curvature(t, block, weight, model, priors),
    }
    compiled = {name: jax.jit(f).lower(theta).compile() for name, f in fns.items()}
    hlo = compiled["hessian_fwd_over_rev"].as_text()
    width = int(block.mask.shape[0])
    multiplies = len(re.findall(rf"f64\[{theta.shape[0]},{width}\]\{{[0-9,]*\}} multiply\(", hlo))
    return compiled, theta, multiplies


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    block, n_windows = one_step()
    compiled, thetas, swell = {}, {}, {}
    for model in MODELS:
        fns, theta, multiplies = programs(model, block)
        for name, f in fns.items():
            compiled[model, name] = f
            thetas[model, name] = theta
            jax.block_until_ready(f(theta))
        swell[model] = multiplies
    times = {key: [] for key in compiled}
    for _ in range(args.repeats):
        for key, f in compiled.items():
            t0 = time.perf_counter()
            jax.block_until_ready(f(thetas[key]))
            times[key].append(time.perf_counter() - t0)
    fastest_us = {
        model: {name: 1e6 * min(times[model, name]) for (k, name) in compiled if k == model}
        for model in MODELS
    }
    result = {
        "benchmark": "online_curvature_cost",
        "step": {"padded_width": int(block.mask.shape[0]), "windows": n_windows},
        "parameters": {model: int(thetas[model, "value"].shape[0]) for model in MODELS},
        "repeats": args.repeats,
        "fastest_us": fastest_us,
        "hessian_over_gradient": {
            k: fastest_us[k]["hessian_fwd_over_rev"] / fastest_us[k]["gradient"] for k in MODELS
        },
        "hessian_over_jacobian": {
            k: fastest_us[k]["hessian_fwd_over_rev"]
            / fastest_us[k]["jacobian_of_window_quantities"]
            for k in MODELS
        },
        "hessian_over_gauss_newton": {
            k: fastest_us[k]["hessian_fwd_over_rev"] / fastest_us[k]["gauss_newton"] for k in MODELS
        },
        "hessian_multiplies_on_directions_by_windows": swell,
        "threads": "one core (sched_setaffinity before JAX started), XLA single-threaded",
        "machine": machine(),
        "note": "each time includes one call's dispatch from Python (tens of microseconds)",
    }
    write_result("online_curvature_cost", result, path=args.out)
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
