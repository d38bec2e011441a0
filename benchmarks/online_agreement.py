"""The online estimator against the batch posterior and the truth, beside a linear-model EKF.

Drives: simulated drives of the package's recovery kind (``tyre_recovery.py``: Magic Formula
tyres of database shapes, the car and its tyres' heating drawn around the files, one ABS stop)
and the external drives (``../shared/data/external``, an independent generator; validation
only: nothing here was tuned to them). Each runs through the stream pipeline into windows, then

* the online estimator from the type prior (default model ``magic``, steps of 30 s on the clock;
  ``--max-step-s`` packs sparse driving, ``window_blocks``);
* the batch fast fit (``fit_tyre(method="fast")``) of the first 10 minutes of windows (the
  external drives last 10 minutes: all of them);
* the linear-slip EKF (:mod:`tyrebayes.inference.online.linear_ekf`), the usual in-car approach.

Reported, per drive and pooled:

* agreement after 10 minutes: |online mean − batch mean| ≤ batch sd and online sd within ±30 %
  of the batch sd (target: ≥ 90 % of drives);
* coverage of the truth by the online 90 % interval at every whole minute, by the estimate in
  force then (the last step's at or before it; target 90 ± 5 points), over the minutes where
  the value is reported (enough evidence) and over all minutes, with a 90 % interval of the
  reported figure from resampling whole drives (a drive's minutes share one posterior); the
  EKF's the same way;
* time to a useful estimate (90 % interval of C_x within ±10 %, the readiness width) for the
  online estimator (its "enough evidence" flag, which also asks for excitation) and the EKF,
  and whether the estimate at that time is within 10 % of the truth.

Truth C_x: the simulated drives' driven-wheel C_x(T) averaged over the drive so far (the online
estimate is C_x at the mean tyre temperature so far); the external drives' ``c_x``.

Usage: ``python benchmarks/online_agreement.py [--sim N] [--duration S] [--no-external]
[--max-step-s S] [--out PATH]`` (16
simulated drives by default, as many as the external ones).
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from pathlib import Path

import jax
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from _internal import MAX_LABEL_LOG_BAYES_FACTOR, MAX_MU_PRIOR_SDS  # noqa: E402
from _online_common import (  # noqa: E402
    external_entries,
    external_windows,
    machine,
    simulated_windows,
    true_c_x_so_far,
)

from tyrebayes import fit_tyre, stack_drives  # noqa: E402
from tyrebayes.inference.online import (  # noqa: E402
    OnlineEstimator,
    linear_ekf,
    pad_steps,
    run_online,
    stream_steps,
)

RESULTS = Path(__file__).parent / "results" / "online_agreement.json"
AGREEMENT_S = 600.0
Z90 = 1.6448536269514722


def one_drive(name, windows, truth_at, n_steps, estimator, source, max_step_s=None) -> dict:
    steps = stream_steps(windows, max_step_s=max_step_s)
    n = steps.n_blocks
    t0 = time.perf_counter()
    traj = run_online(estimator, estimator.init(), pad_steps(steps, n_steps)).trajectory
    jax.block_until_ready(traj)
    online_wall = time.perf_counter() - t0
    ekf = linear_ekf(pad_steps(steps, n_steps))
    times = np.asarray(traj.time_s)[:n]
    mean, sd = np.asarray(traj.c_x.mean)[:n], np.asarray(traj.c_x.sd)[:n]
    low, high = np.asarray(traj.c_x.low)[:n], np.asarray(traj.c_x.high)[:n]
    ready = np.asarray(traj.ready)[:n]
    e_mean, e_sd = np.asarray(ekf.c_x_mean)[:n], np.asarray(ekf.c_x_sd)[:n]
    truth = truth_at(times)

    at = int(np.searchsorted(times, AGREEMENT_S + 1e-9) - 1)
    first10 = windows.select(windows.time_s <= AGREEMENT_S)
    batch = fit_tyre(stack_drives([first10], ["dry"]), method="fast", seed=0)
    b = batch.draws("c_x")
    b_mean, b_sd = float(b.mean()), float(b.std())
    agree_mean = abs(mean[at] - b_mean) <= b_sd
    agree_sd = abs(sd[at] / b_sd - 1.0) <= 0.3

    # The estimate in force at each whole minute: the last step's at or before it (a packed
    # step ends off the minute; a minute without windows keeps the estimate it had).
    grid = np.arange(60.0, times[-1] + 1e-9, 60.0)
    minute = np.searchsorted(times, grid + 1e-9) - 1
    grid, minute = grid[minute >= 0], minute[minute >= 0]
    cover = (low <= truth) & (truth <= high)
    e_cover = np.abs(e_mean - truth) <= Z90 * e_sd
    e_useful = Z90 * e_sd <= 0.1 * e_mean

    def first_time(flags):
        idx = np.flatnonzero(flags)
        return float(times[idx[0]]) if idx.size else None

    def error_at(flags, values):
        idx = np.flatnonzero(flags)
        return float(values[idx[0]] / truth[idx[0]] - 1.0) if idx.size else None

    return {
        "name": name,
        "source": source,
        "n_windows": len(windows),
        "n_abs_windows": int(np.sum(windows.at_limit)),
        "n_steps": int(n),
        "online_wall_s": online_wall,
        "c_x_true_at_10min": float(truth[at]),
        "batch_converged": bool(batch.diagnostics.converged),
        "batch_mean": b_mean,
        "batch_sd": b_sd,
        "online_time_s": float(times[at]),
        "online_mean": float(mean[at]),
        "online_sd": float(sd[at]),
        "online_ready_at_10min": bool(ready[at]),
        "mean_diff_in_batch_sd": float((mean[at] - b_mean) / b_sd),
        "sd_ratio": float(sd[at] / b_sd),
        "agree": bool(agree_mean and agree_sd),
        "minutes": grid.tolist(),
        "online_cover_90": cover[minute].tolist(),
        "online_ready": ready[minute].tolist(),
        "ekf_cover_90": e_cover[minute].tolist(),
        "online_err_at_end": float(mean[-1] / truth[-1] - 1.0),
        "ekf_err_at_end": float(e_mean[-1] / truth[-1] - 1.0),
        "online_time_to_useful_s": first_time(ready),
        "online_err_when_useful": error_at(ready, mean),
        "ekf_time_to_useful_s": first_time(e_useful),
        "ekf_err_when_useful": error_at(e_useful, e_mean),
        "n_alarms": int(np.asarray(traj.n_alarms)[n - 1]),
        # The prior-conflict check (summary.py): how near the tyre's checked coordinates came to
        # its limit on a drive labelled as driven, and the steps it withheld.
        "conflict_prior_sds_max": float(np.max(np.abs(np.asarray(traj.conflict_prior_sds)[:n]))),
        "conflict_joint_prior_sds_max": float(
            np.max(np.asarray(traj.conflict_joint_prior_sds)[:n])
        ),
        "prior_conflict_steps": int(np.sum(np.asarray(traj.prior_conflict)[:n])),
        "mu_label_in_doubt_steps": int(
            np.sum(
                np.asarray(traj.mu_observed)[:n]
                & (
                    (np.abs(np.asarray(traj.mu_prior_z)[:n]) > MAX_MU_PRIOR_SDS)
                    | (np.asarray(traj.mu_label_log_bf)[:n] > MAX_LABEL_LOG_BAYES_FACTOR)
                )
            )
        ),
    }


def _drive_bootstrap_90(per_drive: list[list[bool]], n: int = 4000) -> list[float] | None:
    """5 % and 95 % quantiles of the pooled share over drives resampled with replacement."""
    per_drive = [c for c in per_drive if c]
    if not per_drive:
        return None
    hits = np.asarray([sum(c) for c in per_drive], dtype=float)
    counts = np.asarray([len(c) for c in per_drive], dtype=float)
    pick = np.random.default_rng(0).integers(0, len(per_drive), (n, len(per_drive)))
    shares = hits[pick].sum(axis=1) / counts[pick].sum(axis=1)
    return [float(q) for q in np.quantile(shares, [0.05, 0.95])]


def pooled(rows: list[dict]) -> dict:
    ok = [r for r in rows if r["batch_converged"]]
    cover_ready = [
        c for r in ok for c, k in zip(r["online_cover_90"], r["online_ready"], strict=True) if k
    ]
    cover_all = [c for r in ok for c in r["online_cover_90"]]
    ekf_cover = [c for r in ok for c in r["ekf_cover_90"]]

    def times(key):
        values = [r[key] for r in ok]
        got = [v for v in values if v is not None]
        return {
            "median_min": float(np.median(got) / 60.0) if got else None,
            "n_reached": len(got),
            "n": len(values),
        }

    def within(key):
        got = [r[key] for r in ok if r[key] is not None]
        return float(np.mean(np.abs(got) <= 0.1)) if got else None

    share = float(np.mean([r["agree"] for r in ok])) if ok else None
    coverage = float(np.mean(cover_ready)) if cover_ready else None
    # A drive's minutes share its posterior, so they are far from independent: the figure's
    # uncertainty is that of resampling whole drives.
    coverage_interval = _drive_bootstrap_90(
        [[c for c, k in zip(r["online_cover_90"], r["online_ready"], strict=True) if k] for r in ok]
    )
    return {
        "n_drives": len(rows),
        "n_batch_not_converged": len(rows) - len(ok),
        "agreement_share": share,
        "agreement_target_met": bool(share is not None and share >= 0.9),
        "mean_within_batch_sd_share": float(
            np.mean([abs(r["mean_diff_in_batch_sd"]) <= 1 for r in ok])
        ),
        "sd_within_30pct_share": float(np.mean([abs(r["sd_ratio"] - 1) <= 0.3 for r in ok])),
        "sd_ratio_median": float(np.median([r["sd_ratio"] for r in ok])),
        "online_coverage_90_reported": coverage,
        "online_coverage_90_reported_n": len(cover_ready),
        "online_coverage_90_reported_drive_bootstrap_90": coverage_interval,
        "coverage_target_met": bool(coverage is not None and abs(coverage - 0.9) <= 0.05),
        "online_coverage_90_all_minutes": float(np.mean(cover_all)) if cover_all else None,
        "ekf_coverage_90_all_minutes": float(np.mean(ekf_cover)) if ekf_cover else None,
        "online_time_to_useful": times("online_time_to_useful_s"),
        "ekf_time_to_useful": times("ekf_time_to_useful_s"),
        "online_useful_within_10pct_of_truth": within("online_err_when_useful"),
        "ekf_useful_within_10pct_of_truth": within("ekf_err_when_useful"),
        "online_abs_err_at_end_median": float(np.median([abs(r["online_err_at_end"]) for r in ok])),
        "ekf_abs_err_at_end_median": float(np.median([abs(r["ekf_err_at_end"]) for r in ok])),
        "n_alarms_total": int(sum(r["n_alarms"] for r in ok)),
        "conflict_prior_sds_max": float(max(r["conflict_prior_sds_max"] for r in rows)),
        "conflict_joint_prior_sds_max": float(max(r["conflict_joint_prior_sds_max"] for r in rows)),
        "prior_conflict_steps_total": int(sum(r["prior_conflict_steps"] for r in rows)),
        "mu_label_in_doubt_steps_total": int(sum(r["mu_label_in_doubt_steps"] for r in rows)),
    }


def _print_row(row: dict) -> None:
    """One drive's headline figures as a JSON line (progress of a long run)."""
    keys = ("name", "agree", "sd_ratio", "mean_diff_in_batch_sd", "online_time_to_useful_s")
    print(json.dumps({k: row[k] for k in keys}), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim", type=int, default=16)
    parser.add_argument("--duration", type=float, default=720.0)
    parser.add_argument("--no-external", action="store_true")
    parser.add_argument(
        "--max-step-s", type=float, default=None, help="pack sparse driving (window_blocks)"
    )
    parser.add_argument("--out", default=str(RESULTS))
    args = parser.parse_args()
    estimator = OnlineEstimator.create()
    n_steps = int(np.ceil(args.duration / 30.0)) + 1
    start = time.perf_counter()
    rows = []
    for seed in range(args.sim):
        windows, truth, _ = simulated_windows(seed, args.duration)
        rows.append(
            one_drive(
                f"sim{seed}",
                windows,
                lambda t, tr=truth: true_c_x_so_far(tr, t),
                n_steps,
                estimator,
                "simulated",
                args.max_step_s,
            )
        )
        _print_row(rows[-1])
    if not args.no_external:
        for entry in external_entries():
            windows = external_windows(entry)
            rows.append(
                one_drive(
                    entry["name"],
                    windows,
                    lambda t, c=entry["c_x"]: np.full(len(t), c),
                    n_steps,
                    estimator,
                    "external",
                    args.max_step_s,
                )
            )
            _print_row(rows[-1])
    result = {
        "benchmark": "online_agreement",
        "model": estimator.model,
        "step_s": 30.0,
        "max_step_s": args.max_step_s or 30.0,
        "simulated_duration_s": args.duration,
        "targets": {
            "agreement_at_10min": "≥ 90 % of drives: |mean diff| ≤ batch sd and sd within ±30 %",
            "coverage_90": "0.90 ± 0.05 over time",
            "useful": "90 % interval of C_x within ±10 %",
        },
        "note": (
            "force-density scores are estimated over each stream (a look-ahead of the force "
            "distribution only); external drives are validation only, nothing was tuned to them"
        ),
        "pooled": {
            "all": pooled(rows),
            "simulated": pooled([r for r in rows if r["source"] == "simulated"]),
            "external": pooled([r for r in rows if r["source"] == "external"]),
        },
        "drives": rows,
        "wall_s": time.perf_counter() - start,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "machine": machine(),
    }
    write_result("online_agreement", result, path=args.out)
    print(json.dumps(result["pooled"], indent=2))


if __name__ == "__main__":
    main()
