"""The in-car lateral estimator on the external cornering drives: agreement, jumps, speed.

The drives are in ``../shared/data/external_lateral`` (8 ten-minute drives from a generator
written apart from the package; ``lateral_external.py`` says what they hold). Each is read,
validated and cut into cornering observations as ``fit-tyre`` does; the batch lateral fit
(``fit_lateral``, Laplace) and the online estimator (``tyrebayes.inference.online.lateral``, 30 s
blocks) read the same observations, and the openpilot-paramsd-style EKF of ``paramsd_ekf.py``
the same signals at their own rate. Nothing is tuned to these drives.

Figures (issue 59, item 4):

* **agreement**: the share of drives where the online mean after 10 minutes of driving (the
  drive's end) lies within one batch posterior sd of the batch mean, for c_y front, c_y rear and
  the understeer gradient each (target ≥ 0.9), whether or not the online estimate is "ready" yet
  (that is counted beside it); the paramsd-style EKF's share for comparison.
* **truth**: the share of the 24 quantities (3 per drive) whose online 90 % interval covers the
  generator's truth, and the batch fit's share beside it (no target: where online and batch
  differ, it says which is nearer the truth);
* **jumps in braking corners**: blocks that hold at least 1 s of braking in a corner (a_x, the
  derivative of the low-passed V_x, below −:data:`BRAKING_MPS2` while |a_y| >
  :data:`CORNER_AY_MPS2`). For each such block and each reported estimate, the move of its
  mean over the block against the width of its 90 % interval before it; the largest (target
  ≤ 1). Only estimates reported (ready) before the block count: an estimate still "not yet"
  is learning from its prior and is not shown.
* **speed**: the drive's duration over the compiled estimator's CPU time for all its blocks
  (the median of ``--reps`` runs), on one core (the process pinned to one CPU before JAX
  starts, XLA single-threaded); the median over drives (target ≥ 1e5). CPU time, not wall
  time: on a machine shared with other jobs the wall clock counts their time too. The
  observations' filtering is not included (it is the batch fit's too).

Usage: ``python benchmarks/online_lateral.py [DIR] [--drives l00,l01] [--reps 15]``.
"""

from __future__ import annotations

import os

from _data import EXTERNAL_LATERAL, Drive, external_lateral_drives  # noqa: E402
from _results import figure, write_result  # noqa: E402

os.environ["XLA_FLAGS"] = os.environ.get("XLA_FLAGS", "") + " --xla_cpu_multi_thread_eigen=false"
CORE = max(os.sched_getaffinity(0))
os.sched_setaffinity(0, {CORE})

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from _internal import prior_k_sd, run_online_lateral  # noqa: E402
from paramsd_ekf import run_paramsd  # noqa: E402

from tyrebayes import cornering_observations, fit_lateral, lateral_blocks  # noqa: E402
from tyrebayes.inference.online import OnlineLateralEstimator  # noqa: E402

KEYS = ("c_y_front", "c_y_rear", "understeer_gradient")
#: Braking in a corner: a_x below minus this [m/s²] (the drives brake gently in corners: a_x
#: below −1.5 m/s² at |a_y| > 2 m/s² for under 2 s per drive; below −1 for up to 12 s) ...
BRAKING_MPS2 = 1.0
#: ... while |a_y| is above this [m/s²], for at least this long in a block [s].
CORNER_AY_MPS2 = 2.0
MIN_BRAKING_CORNER_S = 1.0
#: The agreement is read after this much driving [s].
AGREEMENT_S = 600.0


def _ekf(frame, vehicle) -> dict:
    speed = frame[["wheel_speed_rl", "wheel_speed_rr"]].to_numpy().mean(axis=1)
    d = run_paramsd(
        frame["time"].to_numpy(),
        speed * float(vehicle.wheel_radius_m),
        frame["yaw_rate"].to_numpy(),
        frame["steering_wheel_angle"].to_numpy(),
        vehicle,
    ).to_dict()
    return {k: {"mean": d[k]["mean"], "sd": d[k]["sd"]} for k in KEYS}


def _jumps(blocks, trajectory, ready_k, ready_split) -> tuple[list[dict], float]:
    """Braking-in-corner blocks and each reported estimate's move over them / its 90 % width."""
    ax = np.asarray(blocks.ax)
    ay = np.asarray(blocks.ay)
    valid = np.asarray(blocks.speed) > 3.0
    braking = valid & (ax < -BRAKING_MPS2) & (np.abs(ay) > CORNER_AY_MPS2)
    seconds = braking.sum(axis=1) * blocks.dt_s
    est = trajectory.estimates()
    rows, worst = [], 0.0
    for i in np.flatnonzero(seconds >= MIN_BRAKING_CORNER_S):
        if i == 0:
            continue
        row = {"block": int(i), "time_s": float(trajectory.time_s[i]), "seconds": float(seconds[i])}
        for key in KEYS:
            shown = ready_k[i - 1] if key == "understeer_gradient" else ready_split[i - 1]
            if not shown:
                row[key] = None
                continue
            e = est[key]
            width = e["high"][i - 1] - e["low"][i - 1]
            ratio = abs(e["mean"][i] - e["mean"][i - 1]) / width
            row[key] = float(ratio)
            worst = max(worst, float(ratio))
        rows.append(row)
    return rows, worst


def _drive(drive: Drive, reps: int) -> dict:
    name, truth = drive.path.name, drive.truth
    vehicle = drive.vehicle()
    validated = drive.validated(vehicle)
    obs = cornering_observations(validated.data, vehicle)
    batch = fit_lateral(obs, surface=truth["surface"], inputs=(name,))
    b = batch.to_dict()
    blocks = lateral_blocks(obs)
    estimator = OnlineLateralEstimator.create(
        surface=truth["surface"], steering_ratio=float(vehicle.steering_ratio)
    )
    state0 = estimator.init()
    last, trajectory = run_online_lateral(estimator, state0, blocks)
    jax.block_until_ready(last.mean)
    times = []
    for _ in range(reps):
        start = time.process_time()
        out = run_online_lateral(estimator, state0, blocks)
        jax.block_until_ready(out[0].mean)
        times.append(time.process_time() - start)
    seconds = float(np.median(times))
    # The state after AGREEMENT_S of driving: the block ending there (or the last).
    ends = np.asarray(trajectory.time_s)
    at = int(min(np.searchsorted(ends, AGREEMENT_S - 1e-6), len(ends) - 1))
    result = estimator.result(last)
    online = result.unconditional()
    # Readiness along the way (the trajectory's moments; the rule of OnlineLateral).
    est = trajectory.estimates()
    prior_sd = float(result.prior_log_c_y_sd)
    log_sd = np.sqrt(np.diagonal(np.asarray(trajectory.log_c_y_cov), axis1=1, axis2=2))
    k_limit = result.contraction * prior_k_sd(float(result.prior_log_c_y_mean), prior_sd)
    ready_k = np.asarray(trajectory.vif_settled) & (est["understeer_gradient"]["sd"] <= k_limit)
    ready_split = ready_k & np.all(log_sd <= result.contraction * prior_sd, axis=1)
    jump_rows, worst = _jumps(blocks, trajectory, ready_k, ready_split)
    ekf = _ekf(validated.data, vehicle)
    row = {
        "drive": name,
        "kind": truth["kind"],
        "vehicle": truth["vehicle"],
        "batch_converged": bool(b["converged"]),
        "batch_convergence_reasons": list(batch.fit.diagnostics.reasons),
        "batch_identified": bool(b["identified"]),
        "online_at_s": float(ends[at]),
        "online_ready": bool(result.split_identified),
        "online_k_ready": bool(result.k_identified),
        "online_reason": result.reason(),
        "first_ready_s": float(ends[np.argmax(ready_split)]) if ready_split.any() else None,
        "first_k_ready_s": float(ends[np.argmax(ready_k)]) if ready_k.any() else None,
        "samples_skipped_longitudinal": int(result.n_skipped_longitudinal),
        "samples": int(result.n_samples),
        "steering_vif": float(result.steering_vif),
        "kinematic_vif": float(result.kinematic_vif),
        "batch_vif": json.loads(batch.fit.data.attrs["lateral_vif"]),
        "online_s": seconds,
        "real_time_factor": obs.duration_s / seconds,
        "braking_corner_blocks": jump_rows,
        "max_jump_over_interval": worst,
    }
    for key in KEYS:
        batch_sd = b[key]["sd"]
        row[key] = {
            "truth": truth[key],
            "batch": b[key],
            "online": online[key],
            "online_batch_sds": (online[key]["mean"] - b[key]["mean"]) / batch_sd,
            "ekf": ekf[key],
            "ekf_batch_sds": (ekf[key]["mean"] - b[key]["mean"]) / batch_sd,
        }
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=EXTERNAL_LATERAL)
    parser.add_argument("--drives", default="", help="comma-separated drive names (default all)")
    parser.add_argument("--reps", type=int, default=15, help="timed runs per drive")
    args = parser.parse_args()
    rows = []
    for drive in external_lateral_drives(args.folder, args.drives):
        name = drive.path.name
        row = _drive(drive, args.reps)
        rows.append(row)
        print(
            name,
            row["kind"],
            " ".join(f"{k} {row[k]['online_batch_sds']:+.2f}sd" for k in KEYS),
            f"ready {row['online_ready']} K {row['online_k_ready']}",
            f"jump {row['max_jump_over_interval']:.2f}",
            f"x{row['real_time_factor']:.3g}",
            flush=True,
        )
    used = [r for r in rows if r["batch_converged"]]
    excluded = {
        r["drive"]: "batch fit not converged: " + "; ".join(r["batch_convergence_reasons"])
        for r in rows
        if not r["batch_converged"]
    }
    within = [all(abs(r[k]["online_batch_sds"]) <= 1.0 for k in KEYS) for r in used]
    per_key = {k: sum(abs(r[k]["online_batch_sds"]) <= 1.0 for r in used) for k in KEYS}
    ekf_within = [all(abs(r[k]["ekf_batch_sds"]) <= 1.0 for k in KEYS) for r in used]

    def covers(r, k, source):
        low, high = r[k][source]["hdi_90"]
        return low <= r[k]["truth"] <= high

    online_covers = [covers(r, k, "online") for r in used for k in KEYS]
    batch_covers = [covers(r, k, "batch") for r in used for k in KEYS]
    braking_blocks = [j for r in rows for j in r["braking_corner_blocks"]]
    judged = [j for j in braking_blocks if any(j[k] is not None for k in KEYS)]
    worst = max((r["max_jump_over_interval"] for r in rows), default=None)
    factors = [r["real_time_factor"] for r in rows]
    figures = [
        figure(
            "online within one batch sd of the batch mean after 10 min (c_y front, rear and K)",
            float(np.mean(within)) if used else None,
            target=(">=", 0.9),
            count=len(used),
            exclusions=excluded,
            note=(
                f"{sum(within)} of {len(used)} drives; per quantity "
                + ", ".join(f"{k} {v}/{len(used)}" for k, v in per_key.items())
                + f"; online ready (front/rear told apart) on "
                f"{sum(r['online_ready'] for r in rows)}, understeer gradient identified on "
                f"{sum(r['online_k_ready'] for r in rows)}"
            ),
            headline=True,
        ),
        *(
            figure(
                name,
                float(np.mean(hits)) if hits else None,
                count=len(hits),
                exclusions=excluded,
                note=f"{sum(hits)} of {len(hits)}",
            )
            for name, hits in (
                (
                    "online 90 % intervals after 10 min covering the truth (c_y front, rear and K)",
                    online_covers,
                ),
                (
                    "batch 90 % intervals covering the truth (c_y front, rear and K), "
                    "for comparison",
                    batch_covers,
                ),
            )
        ),
        figure(
            "baseline paramsd-style EKF within one batch sd of the batch mean (all three)",
            float(np.mean(ekf_within)) if used else None,
            count=len(used),
            exclusions=excluded,
        ),
        figure(
            "largest move in a braking-corner block over the estimate's 90 % interval",
            worst if judged else None,
            target=("<=", 1.0),
            met=None if not judged else worst <= 1.0,
            count=len(judged),
            note=(
                f"{len(braking_blocks)} blocks with ≥ {MIN_BRAKING_CORNER_S:g} s of a_x < "
                f"−{BRAKING_MPS2:g} m/s² at |a_y| > {CORNER_AY_MPS2:g} m/s² over {len(rows)} "
                f"drives, {len(judged)} with an estimate reported before them"
            ),
            headline=True,
        ),
        figure(
            "online lateral speed, multiple of real time on one core (median over drives)",
            float(np.median(factors)) if factors else None,
            unit="x",
            target=(">=", 1e5),
            count=len(rows),
            note=(
                "30 s blocks, compiled, the estimator alone; CPU time on one core, median of "
                f"{args.reps} runs per drive (slowest drive x{min(factors):.3g})"
                if factors
                else ""
            ),
            headline=True,
        ),
    ]
    payload = {
        "folder": str(args.folder),
        "settings": {
            "braking_mps2": BRAKING_MPS2,
            "corner_ay_mps2": CORNER_AY_MPS2,
            "min_braking_corner_s": MIN_BRAKING_CORNER_S,
            "agreement_s": AGREEMENT_S,
            "reps": args.reps,
            "core": CORE,
        },
        "drives": rows,
    }
    path = write_result("online_lateral", payload, figures=figures)
    for f in figures:
        print(f"{f['name']}: {f['value']} (target {f['target']}, met {f['met']})")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
