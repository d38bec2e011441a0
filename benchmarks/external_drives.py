"""Validate the per-tyre inference on drives the package did not make (``../shared/data/external``).

The drives come from an independent generator (Magic Formula tyres of varied shape, front- and
rear-driven cars with body pitch, per-wheel radius errors, IMU bias/scale/noise, road grade, ABS
with every wheel cycling on its own); ``truth.json`` gives each drive's C_x (slope of ρ_x(σ_x) at
zero slip) and μ (peak), and ``eNN_truth.parquet`` per-sample truth at 25 Hz. They are for
validation, not tuning: nothing in the package is fitted to them.

Each drive is fitted as a new user would (``fit-tyre --method fast``: the stream pipeline with
the tyre temperature estimated from the drive, the default model), and beside it

* the plain brush curve (``model="brush"``, the thesis' model) and the linear model, same fit;
* ordinary least squares of force on measured slip over the same slip windows (the thesis' kind).

Reported per drive and pooled: C_x error and whether the 50 % / 90 % intervals cover the truth;
μ_max error and coverage where the fit says μ_max was observed (ABS windows), and whether a drive
without ABS claims it; the fit's ``adequate`` flag with its reasons; and the noise the windows
state against their actual error, read from the per-sample truth: for each slip window the
window mean of the true driven-axle slip and force, the measured minus true after taking out the
drive's slip offset and force gain (least squares: both are parameters of the model, not noise),
its sd against the root-mean-square stated sd. ``stated_pipeline`` is the stream pipeline's
noise (what enters the model), ``stated_fit`` that times the fit's noise scale (λ).

Fits that do not converge are counted and excluded from the error and coverage figures (listed).

``--load-sensitivity`` fits every model with the load sensitivity of the slip stiffness
(``TyrePriors().with_load_sensitivity()``), written to ``external_drives_load_sensitivity.json``
unless ``--out`` says otherwise: these tyres have none, so the run measures what its prior costs.
``--no-blocks`` fits without the 5 s block slip offsets (``TyrePriors(slip_drift_median=0)``),
written to ``external_drives_no_blocks.json``: what the offsets do on drives the package did not
make.

Usage: ``python benchmarks/external_drives.py [DIR] [--out FILE] [--drives e00,e01]
[--load-sensitivity | --no-blocks]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
import tomllib
from pathlib import Path

import jax
from _data import EXTERNAL, Drive, external_drives  # noqa: E402
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from _internal import BLOCK_S  # noqa: E402

from tyrebayes import (  # noqa: E402
    TyrePriors,
    compute_features,
    features_tyre_temperature,
    fit_tyre,
    observations_from_features,
    stack_drives,
)

RESULTS = Path(__file__).parent / "results" / "external_drives.json"
RESULTS_LOAD = RESULTS.with_name("external_drives_load_sensitivity.json")
RESULTS_NO_BLOCKS = RESULTS.with_name("external_drives_no_blocks.json")
SIDE_MODELS = ("brush", "linear")


def window_truth(truth: pd.DataFrame, centres: np.ndarray, half_width: float, axle: str):
    """Mean true driven-axle slip and force over each window [centre ± half_width]."""
    t = truth["time"].to_numpy()
    wheels = ("fl", "fr") if axle == "front" else ("rl", "rr")
    slip = truth[[f"slip_{w}" for w in wheels]].to_numpy().mean(axis=1)
    rho = truth[f"rho_{axle}"].to_numpy()

    def means(x):
        c = np.concatenate([[0.0], np.cumsum(x)])
        lo = np.searchsorted(t, centres - half_width)
        hi = np.searchsorted(t, centres + half_width)
        with np.errstate(invalid="ignore", divide="ignore"):
            return (c[hi] - c[lo]) / (hi - lo)

    return means(slip), means(rho)


def noise_ratio(measured, true, stated_sd, block) -> dict:
    """Stated vs actual window noise after removing an offset and a gain (least squares).

    ``actual`` is the sd of the error with each block's mean error taken out (``block`` per
    window, the model's blocks of ``BLOCK_S``): errors slower than a block are the blocks'
    offsets in the model, not window noise; ``actual_raw`` keeps them.
    """
    ok = np.isfinite(measured) & np.isfinite(true) & np.isfinite(stated_sd)
    x, y = true[ok], measured[ok]
    design = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    error = y - design @ coef
    _, inverse = np.unique(block[ok], return_inverse=True)
    within = error - (np.bincount(inverse, error) / np.bincount(inverse))[inverse]
    actual = float(np.std(within))
    stated = float(np.sqrt(np.mean(stated_sd[ok] ** 2)))
    return {
        "stated": stated,
        "actual": actual,
        "actual_raw": float(np.std(error)),
        "ratio": stated / actual,
        "gain": float(coef[1]),
    }


def interval_covers(draws: np.ndarray, true: float, prob: float) -> bool:
    lo, hi = np.quantile(draws, [(1 - prob) / 2, (1 + prob) / 2])
    return bool(lo <= true <= hi)


def ols_slope(slip: np.ndarray, rho: np.ndarray) -> float:
    s, r = slip - slip.mean(), rho - rho.mean()
    return float(np.sum(s * r) / np.sum(s * s))


def fit_row(fit, c_x_true: float, mu_true: float) -> dict:
    c_x = fit.draws("c_x")
    mu = fit.draws("mu_max")[:, 0]
    summary = fit.summary()
    observed = bool(summary["mu_max_observed"])
    row = {
        "converged": bool(fit.diagnostics.converged),
        "c_x_mean": float(c_x.mean()),
        "c_x_hdi_90": summary["c_x"]["hdi_90"],
        "c_x_err": float(c_x.mean() / c_x_true - 1),
        "c_x_cover_50": interval_covers(c_x, c_x_true, 0.5),
        "c_x_cover_90": interval_covers(c_x, c_x_true, 0.9),
        "c_x_sd_rel": float(c_x.std() / c_x.mean()),
        "mu_observed": observed,
        "mu_mean": float(mu.mean()),
        "mu_err": float(mu.mean() / mu_true - 1),
        "mu_cover_50": interval_covers(mu, mu_true, 0.5),
        "mu_cover_90": interval_covers(mu, mu_true, 0.9),
    }
    for key in ("adequate", "adequacy_reasons", "identified", "load_sensitivity"):
        if key in summary:
            row[key] = summary[key]
    return row


def one_drive(drive: Drive, priors: TyrePriors | None = None) -> dict:
    name, entry = drive.name, drive.truth
    vehicle = drive.vehicle()
    axle = "front" if tomllib.loads(drive.vehicle_path.read_text())["drive"] == "fwd" else "rear"
    stream = drive.validated(vehicle)
    features = compute_features(stream, vehicle)
    temperature = features_tyre_temperature(features, ambient_c=20.0)
    windows = observations_from_features(features, temperature_c=temperature)
    obs = stack_drives([windows], ["dry"])
    t0 = time.perf_counter()
    fits = {"default": fit_tyre(obs, priors=priors, method="fast", seed=0)}
    wall = time.perf_counter() - t0
    for model in SIDE_MODELS:
        fits[model] = fit_tyre(obs, priors=priors, method="fast", seed=0, model=model)

    truth = drive.truth_samples()
    slip_windows = windows.select(~windows.at_limit)
    true_slip, true_rho = window_truth(truth, slip_windows.time_s, 0.125, axle)
    slip, rho = slip_windows.slip, slip_windows.rho
    post = fits["default"]
    lam_rho = float(post.draws("rho_noise_scale").mean())
    lam_slip = float(post.draws("slip_noise_scale").mean())
    block = np.floor(slip_windows.time_s / BLOCK_S)
    noise = {
        "force": noise_ratio(rho, true_rho, slip_windows.rho_sd, block),
        "slip": noise_ratio(slip, true_slip, slip_windows.slip_sd, block),
    }
    noise["force"]["stated_fit_ratio"] = noise["force"]["ratio"] * lam_rho
    noise["slip"]["stated_fit_ratio"] = noise["slip"]["ratio"] * lam_slip
    # The secant slope of the truth over the forces this drive used (what the data identify).
    ok = np.isfinite(true_slip) & np.isfinite(true_rho) & (np.abs(true_slip) > 0)
    true_secant = float(np.sum(true_rho[ok] * true_slip[ok]) / np.sum(true_slip[ok] ** 2))
    row = {
        "name": name,
        "vehicle": entry["vehicle"],
        "c_x_true": entry["c_x"],
        "mu_true": entry["mu"],
        "shape_C": entry["shape"],
        "curv_E": entry["curv"],
        "n_abs_starts": len(entry["abs_starts"]),
        "n_windows": int(obs.n_used),
        "n_abs_windows": int(obs.n_limit),
        "fit_wall_s": wall,
        "true_secant_over_c_x": true_secant / entry["c_x"],
        "rho_abs_p90": float(np.quantile(np.abs(rho), 0.9)),
        "noise": noise,
        "ols_c_x": ols_slope(slip, rho),
        "ols_c_x_err": ols_slope(slip, rho) / entry["c_x"] - 1,
    }
    for key, fit in fits.items():
        row[key] = fit_row(fit, entry["c_x"], entry["mu"])
    return row


def pooled(rows: list[dict], model: str) -> dict:
    done = [r for r in rows if r[model]["converged"]]
    out = {
        "n_drives": len(rows),
        "n_not_converged": len(rows) - len(done),
        "not_converged": [r["name"] for r in rows if not r[model]["converged"]],
    }
    if not done:
        return out
    err = np.array([r[model]["c_x_err"] for r in done])
    out.update(
        c_x_median_err=float(np.median(err)),
        c_x_mean_abs_err=float(np.mean(np.abs(err))),
        c_x_cover_50=int(sum(r[model]["c_x_cover_50"] for r in done)),
        c_x_cover_90=int(sum(r[model]["c_x_cover_90"] for r in done)),
        c_x_sd_rel_median=float(np.median([r[model]["c_x_sd_rel"] for r in done])),
    )
    with_abs = [r for r in done if r["n_abs_starts"] > 0]
    observed = [r for r in with_abs if r[model]["mu_observed"]]
    out.update(
        mu_drives_with_abs=len(with_abs),
        mu_observed=len(observed),
        mu_false_claims=sum(r[model]["mu_observed"] for r in done if r["n_abs_starts"] == 0),
    )
    if observed:
        mu_err = np.array([r[model]["mu_err"] for r in observed])
        out.update(
            mu_mean_abs_err=float(np.mean(np.abs(mu_err))),
            mu_max_abs_err=float(np.max(np.abs(mu_err))),
            mu_cover_50=int(sum(r[model]["mu_cover_50"] for r in observed)),
            mu_cover_90=int(sum(r[model]["mu_cover_90"] for r in observed)),
        )
    if "adequate" in done[0][model]:
        out["n_inadequate"] = sum(not r[model]["adequate"] for r in done)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=EXTERNAL)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--drives", default="", help="comma-separated subset, e.g. e00,e01")
    parser.add_argument(
        "--load-sensitivity", action="store_true", help="fit with the measured tyres' q prior"
    )
    parser.add_argument(
        "--no-blocks", action="store_true", help="fit without the 5 s block slip offsets"
    )
    args = parser.parse_args()
    if args.load_sensitivity and args.no_blocks:
        parser.error("--load-sensitivity and --no-blocks are separate runs: give one")
    priors = None
    if args.load_sensitivity:
        priors = TyrePriors().with_load_sensitivity()
    elif args.no_blocks:
        priors = TyrePriors(slip_drift_median=0.0)
    if args.out is None:
        args.out = (
            RESULTS_LOAD
            if args.load_sensitivity
            else RESULTS_NO_BLOCKS
            if args.no_blocks
            else RESULTS
        )
    t0 = time.perf_counter()
    rows = []
    for drive in external_drives(args.folder, args.drives):
        row = one_drive(drive, priors)
        rows.append(row)
        d = row["default"]
        print(
            f"{row['name']} C_x {d['c_x_mean']:5.1f} [{d['c_x_hdi_90'][0]:5.1f}, "
            f"{d['c_x_hdi_90'][1]:5.1f}] true {row['c_x_true']:5.1f} ({d['c_x_err']:+.1%}) "
            f"brush {row['brush']['c_x_err']:+.1%} linear {row['linear']['c_x_err']:+.1%} "
            f"OLS {row['ols_c_x_err']:+.1%} | mu {d['mu_mean']:.3f} true {row['mu_true']:.3f} "
            f"obs {d['mu_observed']} | noise force {row['noise']['force']['ratio']:.2f} "
            f"slip {row['noise']['slip']['ratio']:.2f} | adequate {d.get('adequate')}",
            flush=True,
        )
    result = {
        "benchmark": "external_drives",
        "folder": str(args.folder),
        "n_drives": len(rows),
        "method": "fast",
        "load_sensitivity": bool(args.load_sensitivity),
        "block_offsets": not args.no_blocks,
        "wall_s": time.perf_counter() - t0,
        "load_avg_1min": os.getloadavg()[0],
        "pooled": {m: pooled(rows, m) for m in ("default", *SIDE_MODELS)},
        "ols_c_x_median_err": float(np.median([r["ols_c_x_err"] for r in rows])),
        "noise_ratio_median": {
            k: float(np.median([r["noise"][k]["ratio"] for r in rows])) for k in ("force", "slip")
        },
        "noise_ratio_fit_median": {
            k: float(np.median([r["noise"][k]["stated_fit_ratio"] for r in rows]))
            for k in ("force", "slip")
        },
        "drives": rows,
    }
    write_result("external_drives", result, path=args.out)
    print(json.dumps({k: v for k, v in result.items() if k != "drives"}, indent=1))


if __name__ == "__main__":
    main()
