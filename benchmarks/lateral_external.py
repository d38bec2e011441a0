"""Lateral inference on cornering drives the package did not make (``external_lateral``).

The drives are in ``../shared/data/external_lateral``.

The 8 ten-minute drives come from a generator written apart from the package: a two-track car on
Magic Formula lateral tyres whose cornering stiffness and peak depend on the wheel load, lateral
and longitudinal load transfer, relaxation, body roll, road bank, a steering ratio that differs
from the vehicle file's nominal one, an offset on the steering sensor, sensor noise and bias.
``truth.json`` gives each drive's c_y front and rear (slope at zero over the static axle load),
the understeer gradient, μ_y and whether the drive used more than 80 % of it. For validation,
not tuning: nothing in the package is fitted to them.

Each drive is read, validated and fitted as ``fit-tyre`` does (``validate_stream`` →
``cornering_observations`` → ``fit_lateral``, Laplace), and beside it the openpilot-paramsd-style
EKF of ``benchmarks/paramsd_ekf.py`` with openpilot's own tuning on the same signals. Reported per
drive: the estimates, 90 % intervals (the EKF's ±2σ), whether they cover the truth, the
front/rear correlation, μ_y's claim, the fit's flags and its time after compilation; pooled: the
issue's figures.

Usage: ``python benchmarks/lateral_external.py [DIR] [--drives l00,l01]``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import jax
from _data import EXTERNAL_LATERAL, Drive, external_lateral_drives  # noqa: E402
from _results import figure, write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from paramsd_ekf import run_paramsd  # noqa: E402

from tyrebayes import cornering_observations, fit_lateral  # noqa: E402

AXLE_KEYS = ("c_y_front", "c_y_rear")


def _interval_row(estimate: dict, truth: float) -> dict:
    lo, hi = estimate["hdi_90"]
    return {
        "mean": estimate["mean"],
        "sd": estimate["sd"],
        "interval": [lo, hi],
        "truth": truth,
        "error": estimate["mean"] / truth - 1.0,
        "covered": bool(lo <= truth <= hi),
    }


def _ekf(frame: pd.DataFrame, vehicle) -> dict:
    speed = frame[["wheel_speed_rl", "wheel_speed_rr"]].to_numpy().mean(axis=1)
    result = run_paramsd(
        frame["time"].to_numpy(),
        speed * float(vehicle.wheel_radius_m),
        frame["yaw_rate"].to_numpy(),
        frame["steering_wheel_angle"].to_numpy(),
        vehicle,
    )
    d = result.to_dict()
    out = {}
    for key in (*AXLE_KEYS, "understeer_gradient", "steering_ratio"):
        lo, hi = d[key]["bounds_2sd"]
        out[key] = {"mean": d[key]["mean"], "sd": d[key]["sd"], "hdi_90": [lo, hi]}
    out["stability"] = result.stability()
    return out


def _fit_drive(drive: Drive) -> dict:
    name, truth = drive.path.name, drive.truth
    vehicle = drive.vehicle()
    validated = drive.validated(vehicle)
    obs = cornering_observations(validated.data, vehicle)
    fit_lateral(obs, surface=truth["surface"])  # compiles (one program per record length)
    start = time.perf_counter()
    fit = fit_lateral(obs, surface=truth["surface"], inputs=(name,))
    seconds = time.perf_counter() - start
    d = fit.to_dict()
    row = {
        "drive": name,
        "kind": truth["kind"],
        "vehicle": truth["vehicle"],
        "surface": truth["surface"],
        "fit_s_after_compile": seconds,
        "converged": d["converged"],
        "convergence_reasons": list(fit.fit.diagnostics.reasons),
        "adequate": d["adequate"],
        "adequacy_reasons": d["adequacy_reasons"],
        "identified": d["identified"],
        "front_rear_correlation": d["front_rear_correlation"],
        "mu_y_observed": d["mu_y_observed"],
        "mu_y_observed_truth": truth["mu_y_observed"],
        "mu_y": None if d["mu_y"] is None else _interval_row(d["mu_y"], truth["mu_y"]),
        "peak_use": d["peak_use"],
        "peak_use_truth": max(truth["peak_use_front"], truth["peak_use_rear"]),
        "yaw_inertia_factor": d["yaw_inertia_factor"]["mean"],
        "roll_gradient": d["roll_gradient"]["mean"],
        "roll_gradient_truth": truth["roll_gradient_rad_per_mps2"],
        "vif": json.loads(fit.fit.data.attrs["lateral_vif"]),
    }
    for key in (*AXLE_KEYS, "understeer_gradient", "steering_ratio"):
        row[key] = _interval_row(d[key], truth[key])
    ekf = _ekf(validated.data, vehicle)
    row["ekf"] = {
        key: _interval_row(ekf[key], truth[key])
        for key in (*AXLE_KEYS, "understeer_gradient", "steering_ratio")
    }
    row["ekf"]["stability"] = ekf["stability"]
    return row


def _median_abs(rows: list[dict], keys, source=None) -> float:
    errors = [abs((r[source] if source else r)[k]["error"]) for r in rows for k in keys]
    return float(np.median(errors)) if errors else float("nan")


def _coverage(rows: list[dict], keys, source=None) -> tuple[int, int]:
    hits = [(r[source] if source else r)[k]["covered"] for r in rows for k in keys]
    return int(sum(hits)), len(hits)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=EXTERNAL_LATERAL)
    parser.add_argument("--drives", default="", help="comma-separated drive names (default all)")
    args = parser.parse_args()
    rows = []
    for drive in external_lateral_drives(args.folder, args.drives):
        name = drive.path.name
        row = _fit_drive(drive)
        rows.append(row)
        print(
            f"{name} {row['kind']:6s} c_f {row['c_y_front']['error']:+.1%} "
            f"c_r {row['c_y_rear']['error']:+.1%} K {row['understeer_gradient']['error']:+.1%} "
            f"covered {row['c_y_front']['covered']}/{row['c_y_rear']['covered']} "
            f"| EKF c_f {row['ekf']['c_y_front']['error']:+.1%} "
            f"K {row['ekf']['understeer_gradient']['error']:+.1%}",
            flush=True,
        )
    used = [r for r in rows if r["converged"]]
    excluded = {r["drive"]: "not converged: " + "; ".join(r["convergence_reasons"]) for r in rows}
    excluded = {k: v for k, v in excluded.items() if k not in {r["drive"] for r in used}}
    mixed = [r for r in used if r["kind"] == "mixed"]
    hit, n = _coverage(used, AXLE_KEYS)
    ekf_hit, ekf_n = _coverage(rows, AXLE_KEYS, "ekf")
    false_claims = sum(r["mu_y_observed"] and not r["mu_y_observed_truth"] for r in rows)
    claimed = [r for r in used if r["mu_y_observed"] and r["mu_y_observed_truth"]]
    mu_error = float(np.median([abs(r["mu_y"]["error"]) for r in claimed])) if claimed else None
    steady = [r for r in used if r["kind"] == "steady"]
    figures = [
        figure(
            "c_y median |error|, mixed drives",
            100 * _median_abs(mixed, AXLE_KEYS),
            unit="%",
            target=("<=", 5.0),
            count=2 * len(mixed),
            exclusions=excluded,
            headline=True,
        ),
        figure(
            "c_y 90 % interval coverage, all drives",
            hit / max(n, 1),
            target=(">=", 0.8),
            count=n,
            exclusions=excluded,
            note=f"{hit} of {n} axle values",
            headline=True,
        ),
        figure(
            "understeer gradient median |error|",
            100 * _median_abs(used, ("understeer_gradient",)),
            unit="%",
            target=("<=", 10.0),
            count=len(used),
            exclusions=excluded,
            headline=True,
        ),
        figure(
            "fits flagged not adequate",
            sum(not r["adequate"] for r in used),
            count=len(used),
            exclusions=excluded,
            note="; ".join(
                f"{r['drive']}: {', '.join(r['adequacy_reasons'])}"
                for r in used
                if not r["adequate"]
            ),
        ),
        figure(
            "mu_y claimed where the drive did not near it",
            false_claims,
            target=("==", 0),
            count=sum(not r["mu_y_observed_truth"] for r in rows),
        ),
        figure(
            "mu_y median |error| where claimed and neared",
            None if mu_error is None else 100 * mu_error,
            unit="%",
            target=("<=", 10.0),
            met=None if mu_error is None else mu_error <= 0.10,
            count=len(claimed),
            note=(
                f"{sum(r['mu_y_observed_truth'] for r in rows)} drive(s) neared μ_y, "
                f"{len(claimed)} claimed it"
            ),
        ),
        figure(
            "steady drive: front/rear correlation",
            float(np.mean([r["front_rear_correlation"] for r in steady])) if steady else None,
            count=len(steady),
            note="wide, correlated split with a tight understeer gradient",
        ),
        figure(
            "baseline EKF c_y median |error|, mixed drives",
            100 * _median_abs([r for r in rows if r["kind"] == "mixed"], AXLE_KEYS, "ekf"),
            unit="%",
            count=2 * sum(r["kind"] == "mixed" for r in rows),
        ),
        figure(
            "baseline EKF ±2σ coverage of c_y",
            ekf_hit / max(ekf_n, 1),
            count=ekf_n,
            note=f"{ekf_hit} of {ekf_n} axle values",
        ),
        figure(
            "baseline EKF understeer gradient median |error|",
            100 * _median_abs(rows, ("understeer_gradient",), "ekf"),
            unit="%",
            count=len(rows),
        ),
        figure(
            "lateral fit time after compilation, ten-minute drive (median)",
            float(np.median([r["fit_s_after_compile"] for r in rows])),
            unit="s",
            count=len(rows),
        ),
    ]
    payload = {"folder": str(args.folder), "drives": rows}
    path = write_result("lateral_external", payload, figures=figures)
    for f in figures:
        print(f"{f['name']}: {f['value']} (target {f['target']}, met {f['met']})")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
