"""What one burst of outlying slips does to the online estimate: noise scales that revert or not.

A feature error (a tight turn read with the wrong geometry, a wheel-speed glitch) puts a few
seconds of windows far off the curve. With Normal slip errors the filter's Laplace update then
moves the noise scales λ_ρ and λ_σ by tens of their sds. This benchmark simulates drives of the
package's own generator (the online benchmarks' drives: 20 minutes, compact_fwd, a Magic Formula
tyre of a cycled type), adds 20 of each window's slip sds to 40 slip windows (10 s of pushing)
from the first at or after 700 s, and runs the default (Magic Formula) estimator twice:

* ``reverting``: the default configuration, noise scales reverting to their prior with the
  correlation time of :data:`tyrebayes.inference.online.config.REVERSION_S`;
* ``constant``: the same with the noise scales held (correlation time infinite), as the
  estimator was before they reverted.

Reported per run and pooled: change alarms (none is right: the tyre does not change), C_x at the
end against the truth (the mean true C_x over the drive) and its 90 % interval, and how many
type-prior sds each noise scale is from its prior at the end and at its farthest. The same drives
without the burst are run too (the control: what reverting costs where nothing happens).

Usage: ``python benchmarks/online_outliers.py [--drives 12] [--out FILE]``.
"""

from __future__ import annotations

import argparse
import functools
import json
import resource
import sys
import time
from pathlib import Path

import jax
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from _internal import REVERSION_S  # noqa: E402
from _online_common import machine, simulated_windows, true_c_x_so_far  # noqa: E402

from tyrebayes import WindowTable  # noqa: E402
from tyrebayes.inference.online import (  # noqa: E402
    COMPILER_OPTIONS,
    OnlineEstimator,
    default_config,
    pad_steps,
    stream_steps,
)

RESULTS = Path(__file__).parent / "results" / "online_outliers.json"
DURATION_S = 1200.0
BURST_FROM_S = 700.0
BURST_WINDOWS = 40  # 10 s of 0.25 s windows where the car pushes throughout
BURST_SDS = 20.0


def with_burst(windows: WindowTable) -> tuple[WindowTable, float]:
    """The windows with the first BURST_WINDOWS slip windows from BURST_FROM_S on moved by
    BURST_SDS of their own slip sds, and the time of the first."""
    t = windows.time_s
    slip_windows = np.flatnonzero((t >= BURST_FROM_S) & ~windows.at_limit)
    slip_windows = slip_windows[np.argsort(t[slip_windows], kind="stable")][:BURST_WINDOWS]
    moved = windows.slip.copy()
    moved[slip_windows] += BURST_SDS * windows.slip_sd[slip_windows]
    return windows.replace(slip=moved), float(t[slip_windows[0]])


@functools.partial(eqx.filter_jit, compiler_options=COMPILER_OPTIONS)
def _trajectory(estimator: OnlineEstimator, blocks):
    """Every step's summary and θ's mean after it (:meth:`OnlineEstimator.run`'s scan, which
    keeps the summaries only)."""

    def step(state, block):
        state = estimator.update(state, block)
        return state, (estimator.summary(state), state.mean)

    return jax.lax.scan(step, estimator.init(), blocks)[1]


def run(estimator: OnlineEstimator, windows: dict, truth, n_steps: int) -> dict:
    steps = stream_steps(windows)
    n, padded = steps.n_blocks, pad_steps(steps, n_steps)
    traj, means = _trajectory(estimator, padded)
    names = estimator.prior.names
    prior_sd = np.sqrt(np.diag(np.asarray(estimator.prior.cov)))
    path = (np.asarray(means)[:n] - np.asarray(estimator.prior.mean)) / prior_sd
    times = np.asarray(traj.time_s)[:n]
    truth_end = float(true_c_x_so_far(truth, times[-1:])[0])
    mean = float(np.asarray(traj.c_x.mean)[n - 1])
    lo, hi = float(np.asarray(traj.c_x.low)[n - 1]), float(np.asarray(traj.c_x.high)[n - 1])
    noise = {
        name: {
            "prior_sds_end": float(path[-1, i]),
            "prior_sds_max_abs": float(np.max(np.abs(path[:, i]))),
        }
        for i, name in enumerate(names)
        if "noise_scale" in name
    }
    return {
        "alarms_s": times[np.asarray(traj.alarm)[:n]].tolist(),
        "c_x_end": mean,
        "c_x_90_end": [lo, hi],
        "c_x_truth": truth_end,
        "c_x_rel_error_end": mean / truth_end - 1.0,
        "covered_end": bool(lo <= truth_end <= hi),
        "noise_scales": noise,
    }


def pooled(rows: list[dict]) -> dict:
    err = np.abs([r["c_x_rel_error_end"] for r in rows])
    far = [max(v["prior_sds_end"] ** 2 for v in r["noise_scales"].values()) ** 0.5 for r in rows]
    return {
        "n": len(rows),
        "runs_with_alarms": int(sum(bool(r["alarms_s"]) for r in rows)),
        "c_x_abs_rel_error_end_median": float(np.median(err)),
        "c_x_abs_rel_error_end_max": float(np.max(err)),
        "covered_end": int(sum(r["covered_end"] for r in rows)),
        "noise_scale_prior_sds_end_max": float(np.max(far)),
        "noise_scale_prior_sds_end_median": float(np.median(far)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=12)
    parser.add_argument("--out", default=str(RESULTS))
    args = parser.parse_args()
    start = time.perf_counter()
    reverting = OnlineEstimator.create()
    names = reverting.prior.names
    constant = OnlineEstimator.create(
        config=default_config(reversion_s=jnp.full(len(names), jnp.inf))
    )
    n_steps = int(np.ceil(DURATION_S / 30.0)) + 2
    runs = {f"{m}_{b}": [] for m in ("reverting", "constant") for b in ("burst", "clean")}
    for seed in range(args.drives):
        windows, truth, _ = simulated_windows(3000 + seed, DURATION_S)
        burst, burst_s = with_burst(windows)
        for label, est in (("reverting", reverting), ("constant", constant)):
            for case, w in (("burst", burst), ("clean", windows)):
                row = {"seed": 3000 + seed, "burst_s": burst_s, **run(est, w, truth, n_steps)}
                runs[f"{label}_{case}"].append(row)
                print(label, case, json.dumps(row), flush=True)
    result = {
        "benchmark": "online_outliers",
        "model": "magic",
        "duration_s": DURATION_S,
        "burst_from_s": BURST_FROM_S,
        "burst_windows": BURST_WINDOWS,
        "burst_slip_sds": BURST_SDS,
        "reversion_s": REVERSION_S,
        "note": "the package's own simulated drives; alarms are false (the tyre never changes)",
        "pooled": {k: pooled(v) for k, v in runs.items()},
        "runs": runs,
        "wall_s": time.perf_counter() - start,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "machine": machine(),
    }
    print(json.dumps(result["pooled"], indent=2))
    write_result("online_outliers", result, path=args.out)


if __name__ == "__main__":
    main()
