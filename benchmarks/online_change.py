"""Change detection of the online estimator: tyre swaps found, false alarms on unchanged tyres.

* Detection: ``--swaps`` simulated swaps, each a drive of ``--before`` seconds on one tyre
  followed (same car, the windows joined end to end, the second marked as a new drive) by a
  drive of ``--after`` seconds on a tyre whose C_xr is 20 % higher or lower (alternating; same
  type and Magic Formula shape, the other drive's own sensor offsets: a swap changes the rolling
  radii too). Full simulated drives through the stream pipeline. Target: detected within 5
  minutes of driving after the swap in ≥ 90 % of swaps. Alarms before the swap are counted as
  false.
* Controls: the same pairs of drives with the same tyre on both (factor 1): every alarm is
  false. These are the simulator's drives, not the model's: the curve, the noise colour and the
  force density are the simulator's, so this is the false-alarm count under misspecification.
* False alarms under the model: 100 hours of driving without a change would take hours to
  simulate through the 100 Hz pipeline, so the windows are drawn from the model's own likelihood
  instead: the noise sds, temperatures and times of one simulated one-hour drive's windows, and
  for each of ``--cars`` one-hour copies new forces from that drive's deconvolved force mixture
  and slips from the per-tyre model at a fixed θ (Magic Formula curve; drives of 15 minutes, each
  with its own slip offset from the prior; each 5 s block's offset, the slip and force noise, as
  the model says), run through the estimator vmapped. Target: ≤ 1 false alarm per 100 hours.
  This tests the detector's arithmetic where the likelihood is right.
* What the data can tell: for each swap, the batch fast fit of the drive before the swap and of
  the first 5 minutes after it, each alone, and the separation of their log C_x in combined
  posterior sds. No detector with a bounded false-alarm rate finds a swap that the batch
  posterior of the same windows cannot tell from no swap.

Usage: ``python benchmarks/online_change.py [--swaps N] [--cars N] [--max-step-s S] [--out PATH]``
(``--max-step-s``: sparse driving packed into fewer steps, ``window_blocks``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import sys
import time
from pathlib import Path

import jax
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from _internal import BLOCK_S, curve_slip, deconvolve_forces  # noqa: E402
from _online_common import TYRES, machine, simulated_windows  # noqa: E402

from tyrebayes import TyrePriors, WindowTable, fit_tyre, stack_drives  # noqa: E402
from tyrebayes.inference.online import (  # noqa: E402
    OnlineEstimator,
    pad_steps,
    run_online,
    run_online_cars,
    stream_steps,
)
from tyrebayes.physics import stiffness_with_sensitivity  # noqa: E402
from tyrebayes.simulate import TyreSpec, draw_database_curve  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "online_change.json"
STEP = 1.2
DETECT_WITHIN_S = 300.0
DRIVE_S = 900.0
CHUNK_CARS = 25

# θ of the false-alarm windows: a mid-range tyre (C_xr 45, database-like shape C 1.6, E 0.3, dry
# μ 1.0), the per-drive nuisances at their prior medians and the blocks' offsets at the prior
# median τ.
TRUE = {
    "c_xr": 45.0,
    "kappa": 0.008,
    "mu": 1.0,
    "shape_c": 1.6,
    "curvature_e": 0.3,
    "slip_drift_sd": 3e-4,
}


def _first_after(row: dict, before_s: float) -> str:
    """The kind of the first alarm after the swap ("" if none)."""
    after = [k for t, k in zip(row["alarms_s"], row["alarm_kinds"], strict=True) if t > before_s]
    return after[0] if after else ""


def swap_drive(i: int, before_s: float, after_s: float, factor: float) -> WindowTable:
    """Pair ``i``: a drive on one tyre, then one on a tyre with C_xr × ``factor``."""
    rng = np.random.default_rng([i, 11])
    kind = TYRES[i % len(TYRES)]
    first = TyreSpec.from_type(kind, magic_formula=draw_database_curve(rng))
    second = dataclasses.replace(first, c_xr=first.c_xr * factor)
    a, _, _ = simulated_windows(1000 + i, before_s, tyre=first)
    b, _, _ = simulated_windows(2000 + i, after_s, tyre=second)
    # Two drives: the car stops for the swap, and the estimator sees the second drive start.
    a = a.replace(drive=np.zeros(len(a), dtype=int))
    b = b.replace(time_s=b.time_s + before_s, drive=np.ones(len(b), dtype=int))
    return WindowTable.concatenate([a, b])


def batch_separation(windows: WindowTable, before_s: float) -> dict:
    """The batch fast fits of the drive before the swap and of the first DETECT_WITHIN_S after
    it, each alone: their C_x and how many combined sds apart their log C_x are."""
    t = windows.time_s
    parts = {
        "before": t <= before_s,
        "after_5min": (t > before_s) & (t <= before_s + DETECT_WITHIN_S),
    }
    fits = {}
    for name, use in parts.items():
        part = windows.select(use).replace(drive=None)
        draws = np.log(fit_tyre(stack_drives([part], ["dry"]), method="fast", seed=0).draws("c_x"))
        fits[name] = (float(np.mean(draws)), float(np.std(draws)))
    (m0, s0), (m1, s1) = fits["before"], fits["after_5min"]
    return {
        "batch_c_x_before": float(np.exp(m0)),
        "batch_c_x_after_5min": float(np.exp(m1)),
        "batch_separation_sd": abs(m1 - m0) / float(np.hypot(s0, s1)),
    }


def exact_force_scores(rho_obs, noise_sd, mixture) -> tuple[np.ndarray, np.ndarray]:
    """d/dρ log p_i and its slope at each window, p_i the true-force mixture widened by the
    window's own noise: the exact Tweedie inputs the model reads (no density estimate)."""
    var = mixture.variances[None, :] + noise_sd[:, None] ** 2
    dev = rho_obs[:, None] - mixture.means[None, :]
    log_w = np.log(mixture.weights)[None, :] - 0.5 * np.log(var) - 0.5 * dev**2 / var
    resp = np.exp(log_w - log_w.max(axis=1, keepdims=True))
    resp /= resp.sum(axis=1, keepdims=True)
    score = np.sum(resp * -dev / var, axis=1)
    second = np.sum(resp * ((dev / var) ** 2 - 1.0 / var), axis=1)
    return score, second - score**2


def model_windows(template: WindowTable, seed: int) -> WindowTable:
    """Slips and forces drawn from the per-tyre model at TRUE, at the template's times, noise sds
    and temperatures.

    True forces come from a Gaussian mixture (the template drive's deconvolved force density),
    so that each window's E[ρ_true | ρ_obs] is known exactly: the model's likelihood is then the
    data's, and the false-alarm count tests the detector alone. (Re-noising the template's
    measured forces instead gives true forces with the window selection's hard edge, which a
    drive's estimated force density smooths: C_x came out 25 % high on such windows.)
    """
    rng = np.random.default_rng(seed)
    used = template.select(~template.at_limit)
    t, rho_sd, slip_sd = used.time_s, used.rho_sd, used.slip_sd
    mixture = deconvolve_forces(used.rho, rho_sd)
    component = rng.choice(mixture.weights.size, size=t.size, p=mixture.weights)
    rho_true = rng.normal(mixture.means[component], np.sqrt(mixture.variances[component]))
    temperature = used.temperature_c
    c_x = np.asarray(stiffness_with_sensitivity(TRUE["c_xr"], temperature, TRUE["kappa"]))
    params = {"curve_shape_c": TRUE["shape_c"], "curve_curvature_e": TRUE["curvature_e"]}
    slip_true = np.asarray(curve_slip("magic", rho_true, c_x, TRUE["mu"], params))
    block = np.floor(t / BLOCK_S).astype(int)
    offsets = rng.normal(0.0, TRUE["slip_drift_sd"], block.max() + 1)[block]
    # Drives of DRIVE_S: each its own slip offset from the batch model's prior (N(0, 0.004)),
    # so the hour holds drive starts, where the filter's per-drive coordinates restart.
    drive = np.floor(t / DRIVE_S).astype(int)
    drive_offset = rng.normal(0.0, TyrePriors().slip_offset_sd, drive.max() + 1)[drive]
    slip = slip_true + drive_offset + offsets + rng.normal(0.0, slip_sd)
    # Force gain 1: the measured force is the true one plus its noise.
    rho = rho_true + rng.normal(0.0, rho_sd)
    score, slope = exact_force_scores(rho, rho_sd, mixture)
    return WindowTable(
        slip=slip,
        rho=rho,
        slip_sd=slip_sd,
        rho_sd=rho_sd,
        temperature_c=temperature,
        time_s=t,
        at_limit=np.zeros(len(t), dtype=bool),
        rho_score=score,
        rho_score_slope=slope,
        drive=drive,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--swaps", type=int, default=30)
    parser.add_argument("--before", type=float, default=600.0)
    parser.add_argument("--after", type=float, default=360.0)
    parser.add_argument("--cars", type=int, default=100)
    parser.add_argument(
        "--max-step-s", type=float, default=None, help="pack sparse driving (window_blocks)"
    )
    parser.add_argument("--out", default=str(RESULTS))
    args = parser.parse_args()
    start = time.perf_counter()
    estimator = OnlineEstimator.create()
    n_steps = int(np.ceil((args.before + args.after) / 30.0)) + 2

    def run_pair(i: int, factor: float) -> dict:
        windows = swap_drive(i, args.before, args.after, factor)
        steps = stream_steps(windows, max_step_s=args.max_step_s)
        n = steps.n_blocks
        traj = run_online(estimator, estimator.init(), pad_steps(steps, n_steps)).trajectory
        times = np.asarray(traj.time_s)[:n]
        alarmed = np.asarray(traj.alarm)[:n]
        alarms = times[alarmed]
        kinds = np.where(np.asarray(traj.swap_alarm)[:n][alarmed], "swap", "change")
        after = alarms[alarms > args.before]
        delay = float(after[0] - args.before) if after.size else None
        row = {
            "pair": i,
            "c_xr_factor": factor,
            **batch_separation(windows, args.before),
            "alarms_s": alarms.tolist(),
            # Which detector raised each: the drive-start swap test or the mid-drive CUSUM.
            "alarm_kinds": kinds.tolist(),
            "false_alarms_before_swap": int(np.sum(alarms <= args.before)),
            "delay_s": delay,
            "detected_within_5min": bool(delay is not None and delay <= DETECT_WITHIN_S),
            "c_x_before_swap": float(
                np.asarray(traj.c_x.mean)[:n][np.searchsorted(times, args.before) - 1]
            ),
            "c_x_end": float(np.asarray(traj.c_x.mean)[n - 1]),
            # Read after each step, so an alarm's own step shows the reset (0), not its crossing.
            "swap_log_bayes_factor_max_after": float(
                np.max(np.asarray(traj.swap_log_bayes_factor)[:n][times > args.before])
            ),
            "ready_end": bool(np.asarray(traj.ready)[n - 1]),
        }
        print(json.dumps(row), flush=True)
        return row

    swaps = [run_pair(i, STEP if i % 2 == 0 else 1.0 / STEP) for i in range(args.swaps)]
    controls = [run_pair(i, 1.0) for i in range(args.swaps)]

    template, _, _ = simulated_windows(0, 3600.0, abs_events=0)
    per_car = [model_windows(template, seed) for seed in range(args.cars)]
    steps = [stream_steps(w, max_step_s=args.max_step_s) for w in per_car]
    width = max(s.slip.shape[1] for s in steps)
    longest = max(s.n_blocks for s in steps)
    padded = []
    for w in per_car:
        from tyrebayes.inference.online import window_blocks

        padded.append(
            pad_steps(window_blocks(w, "dry", width=width, max_step_s=args.max_step_s), longest)
        )
    cars = jax.tree.map(lambda *x: jnp.stack(x), *padded)
    # Cars in chunks of CHUNK_CARS per call: one call over all 100 hung in XLA's CPU runtime
    # (every thread idle, the result never ready; jaxlib 0.10.2), 30 per call did not.
    t0 = time.perf_counter()
    parts = []
    for lo in range(0, args.cars, CHUNK_CARS):
        chunk = jax.tree.map(lambda x, lo=lo: x[lo : lo + CHUNK_CARS], cars)
        size = chunk.time_s.shape[0]
        states = jax.tree.map(
            lambda x, size=size: jnp.broadcast_to(x, (size, *x.shape)), estimator.init()
        )
        parts.append(jax.block_until_ready(run_online_cars(estimator, states, chunk)))
    run = jax.tree.map(lambda *x: jnp.concatenate(x), *parts)
    final, traj = run.state, run.trajectory
    false_wall = time.perf_counter() - t0
    hours = float(np.sum(np.asarray(cars.time_s)[:, -1]) / 3600.0)
    n_false = int(np.sum(np.asarray(final.n_alarms)))
    armed = np.asarray(traj.c_x.sd / traj.c_x.mean)[:, -1]
    # The largest swap evidence each drive start reached (the first drive of a car has nothing
    # to compare: its challenger and estimate start from the same prior).
    starts = np.asarray(cars.drive_start)
    drive_of_step = np.cumsum(starts, axis=1)
    evidence = np.asarray(traj.swap_log_bayes_factor)
    per_start = [
        float(evidence[c][drive_of_step[c] == d].max())
        for c in range(evidence.shape[0])
        for d in range(2, int(drive_of_step[c].max()) + 1)
    ]

    detected = [s["detected_within_5min"] for s in swaps]
    found = [s for s in swaps if s["detected_within_5min"]]
    pre_hours = args.swaps * args.before / 3600.0
    result = {
        "benchmark": "online_change",
        "model": estimator.model,
        "threshold_nats": float(estimator.config.change_threshold),
        "swap_threshold_nats": float(estimator.config.swap_threshold),
        "shift_log": float(estimator.config.change_log_shift),
        "detection": {
            "n_swaps": len(swaps),
            "detected_within_5min_share": float(np.mean(detected)) if swaps else None,
            "target_share": 0.9,
            "target_met": bool(swaps and np.mean(detected) >= 0.9),
            "delay_median_s": float(np.median([s["delay_s"] for s in swaps if s["delay_s"]]))
            if any(s["delay_s"] for s in swaps)
            else None,
            "false_alarms_before_swaps": int(sum(s["false_alarms_before_swap"] for s in swaps)),
            "found_by": {
                kind: sum(
                    s["detected_within_5min"] and _first_after(s, args.before) == kind
                    for s in swaps
                )
                for kind in ("swap", "change")
            },
            "batch_separation_sd": {
                "detected": [s["batch_separation_sd"] for s in swaps if s["detected_within_5min"]],
                "missed": [s["batch_separation_sd"] for s in swaps if s not in found],
            },
            "hours_before_swaps": pre_hours,
            "swaps": swaps,
        },
        "controls_same_tyre": {
            "n_pairs": len(controls),
            "hours": len(controls) * (args.before + args.after) / 3600.0,
            "drive_starts": len(controls),
            "n_false_alarms": int(sum(len(c["alarms_s"]) for c in controls)),
            "pairs": controls,
            "how": "the swap pairs with the same tyre on both drives (module docstring)",
        },
        "false_alarms_model_windows": {
            "n_cars": args.cars,
            "hours": hours,
            "n_false_alarms": n_false,
            "per_100_hours": 100.0 * n_false / hours,
            "target_per_100_hours": 1.0,
            "target_met": bool(100.0 * n_false / hours <= 1.0),
            "c_x_sd_rel_at_end_median": float(np.median(armed)),
            "wall_s": false_wall,
            "drive_starts": int(np.sum(np.asarray(cars.drive_start))),
            "swap_log_bayes_factor_max_per_drive_start": {
                "n": len(per_start),
                "median": float(np.median(per_start)),
                "q99": float(np.quantile(per_start, 0.99)),
                "max": float(np.max(per_start)),
                "threshold": float(estimator.config.swap_threshold),
            },
            "how": "windows drawn from the per-tyre model at a fixed θ (module docstring)",
        },
        "steps": {"step_s": 30.0, "max_step_s": args.max_step_s or 30.0},
        "wall_s": time.perf_counter() - start,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "machine": machine(),
    }
    write_result("online_change", result, path=args.out)
    print(json.dumps({k: v for k, v in result.items() if k != "detection"}, indent=2))
    print(json.dumps({k: v for k, v in result["detection"].items() if k != "swaps"}, indent=2))
    print(json.dumps({k: v for k, v in result["controls_same_tyre"].items() if k != "pairs"}))


if __name__ == "__main__":
    main()
