"""Tread wear from a car's own drive history with cornering: γ, its interval, per-axle wear rates.

Per simulated year (:func:`tyrebayes.simulate.wear_history.simulate_wear_year`: compact FWD car,
summer tyres, γ = 0.022 mm³/J (the set's true wear, ``true_g_per_1000km_car_set``, inside the
ADAC convoy range), κ = 0.02 /K, commuting drives whose corners and lane changes do about
half of the friction work (:data:`~tyrebayes.simulate.wear_history.COMMUTE_PROFILE`; the truth
wears by the longitudinal and the lateral work, eq. 4.19a + b), 15,000 km a year, a rotation and a
replacement, tread readings every 5,000 km) the pipeline reads only the stream files
(:func:`tyrebayes.wear_evidence_table`), builds the history (tyre changes
detected) and fits γ and κ with the readings (:func:`tyrebayes.inference.wear.fit_wear_history`,
NUTS). Four sources of the cornering stiffness behind the lateral work, each its own fit:

``type_prior``
    what the package uses without a lateral posterior (``fit-wear --type-prior-cornering``)
    (:data:`~tyrebayes.streams.cornering_stiffness.TYPE_PRIOR_CORNERING`: 16.5 /rad, log-sd 0.5; the
    simulated tyre's is 22 /rad).
``lateral_fit``
    the package's default path (``tyrebayes fit-wear`` on stream files): the lateral fit of the
    year's first drive whose fit is usable, up to the first five
    (:func:`tyrebayes.cornering_stiffness_from_drives`), and the type prior in a year where none
    is (counted: ``years_without_usable_lateral_fit``; that year's fit is the type prior's).
    The top-level figures the checks read are this source's.
``drive_lateral``
    the fleet-run path (``fit-wear`` on a fleet run's drive summaries): each drive's lateral
    estimate as a fast fleet run's drive stage makes it
    (:func:`tyrebayes.batch.lateral.drive_lateral`, the in-car estimator's moments), the
    type-prior evidence table put on each tyre set's
    combined axle c_y (:func:`tyrebayes.batch.with_drive_cornering`; the sets are the
    mounted tyre sets, a replacement starting a new one).
``posterior_stand_in``
    a per-axle c_y as a lateral posterior of log-sd 0.1 would give it, drawn as the true c_y
    times exp(0.1 N(0, 1)) per axle: what the wear fit does with an inferred stiffness of that
    precision, whatever the lateral fit reaches.

Tyre changes: found by the radius ratio's step test, each of the right type by that test and
as the fit took it, with the tread readings (a change not found counts as wrong in neither).

Reported per source: γ's own 90 % coverage and its one-year interval half-width (relative), the
bias of γ's median, γ·s (γ per joule of evidence work) beside them, the per-axle wear rates' 90 %
coverage (rear included), and the ratio of the evidence's work to the simulator's true work per
axle and component.

Also per year: the slope of the evidence's radius-ratio drift on the true tread loss (1 where the
ratio follows the wear), which a year's γ error follows; the bias of γ's median over the years is
given with its bootstrap standard error.

Run ``python benchmarks/wear_history.py [--years 10] [--drives 30] [--samples 800] [--jobs 1]``;
results go to ``benchmarks/results/wear_history.json``. Timings are taken on a machine shared
with other jobs.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import multiprocessing
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import jax
from _results import figure, to_jsonable, write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from _internal import WORK_SCALE_LOG_SD, drive_lateral, hdi  # noqa: E402

from tyrebayes import (  # noqa: E402
    CorneringStiffness,
    cornering_stiffness_from_drives,
    drive_history,
    fit_wear_history,
    load_vehicle,
    read_stream,
    tread_readings,
    validate_stream,
    wear_evidence_table,
    wear_history_predictions,
)
from tyrebayes.batch import RunSettings, with_drive_cornering  # noqa: E402
from tyrebayes.physics import TreadGeometry  # noqa: E402
from tyrebayes.simulate import simulate_wear_year  # noqa: E402

GAMMA = 0.022
KAPPA = 0.02
SOURCES = ("type_prior", "lateral_fit", "drive_lateral", "posterior_stand_in")
#: The source whose figures are the headline (and the top-level fields): the package's default.
HEADLINE = "lateral_fit"
STAND_IN_LOG_SD = 0.1
LABELS = {
    "type_prior": "type prior c_y",
    "lateral_fit": "c_y from the lateral fit",
    "drive_lateral": "c_y from the drives' lateral estimates, fleet path",
    "posterior_stand_in": "c_y posterior stand-in",
}
HALF_WIDTH_TARGET = 0.20
GEOM = TreadGeometry()


def _interval(draws: np.ndarray, truth: float) -> dict:
    lo, hi = hdi(draws, 0.9)
    med = float(np.median(draws))
    return {
        "median": med,
        "hdi_90": [float(lo), float(hi)],
        "covers_truth": bool(lo <= truth <= hi),
        "half_width_rel": float((hi - lo) / 2 / med),
    }


def _fit_source(table, truth, seed: int, nuts: dict) -> dict:
    history = drive_history(table)
    readings = tread_readings(truth.readings)
    t0 = time.time()
    fit = fit_wear_history(history, readings, seed=seed, **nuts)
    out = wear_history_predictions(fit, history, readings).to_dict()
    rates = {}
    per_km = np.asarray(truth.wear_mm_per_1000km)  # mm per 1000 km, (front, rear)
    for a, name in enumerate(("front", "rear")):
        s = out["wear_mm_per_1000km"][name]
        lo, hi = s["hdi_90"]
        rates[name] = {
            "true": float(per_km[a]),
            "mean": s["mean"],
            "hdi_90": [lo, hi],
            "covers_truth": bool(lo <= per_km[a] <= hi),
        }
    return {
        "gamma": _interval(fit.draws("gamma"), truth.gamma_mm3_per_j),
        "gamma_work": _interval(fit.draws("gamma_work"), truth.gamma_mm3_per_j),
        "wear_mm_per_1000km": rates,
        "lateral_work": out["lateral_work"],
        "converged": bool(fit.converged),
        "diagnostics": fit.diagnostics.as_dict(),
        "tyre_changes": fit.attr("tyre_changes"),
        "fit_s": time.time() - t0,
    }


def _drift_slope_over_truth(table, truth, radius_m: float) -> float:
    """The year's radius-ratio drift against the true tread loss: 1 where the ratio follows it.

    The least-squares slope of the evidence's front/rear radius ratio (relative) on the true
    front-minus-rear tread depth at each drive's start [mm] times the nominal radius [mm], with
    one offset per tyre-set segment (between tyre changes). The wear fit reads γ·s mostly from
    this drift, so a year's γ error follows its slope: what is left of the ratio's
    drive-to-drive noise after a year's drives.
    """
    depth = np.asarray(truth.depth_mm)
    diff = depth[:, :2].mean(axis=1) - depth[:, 2:].mean(axis=1)
    ratio = table["radius_ratio_front_rear"].to_numpy(dtype=float)
    segment = np.zeros(len(ratio), dtype=int)
    for k in truth.change_drive_index:
        segment[k:] += 1
    offsets = [(segment == s).astype(float) for s in np.unique(segment)]
    design = np.column_stack([diff, *offsets])
    ok = np.isfinite(ratio)
    coef = np.linalg.lstsq(design[ok], ratio[ok], rcond=None)[0]
    return float(coef[0] * radius_m * 1000.0)


def _bootstrap_se(values: list[float], statistic=np.median, draws: int = 4000) -> float | None:
    """Standard error of ``statistic`` over the years, by resampling them (fixed seed)."""
    if len(values) < 2:
        return None
    x = np.asarray(values, dtype=float)
    idx = np.random.default_rng(0).integers(0, x.size, size=(draws, x.size))
    return float(np.std(statistic(x[idx], axis=1)))


def run_year(seed: int, n_drives: int, drive_s: float, nuts: dict) -> dict:
    vehicle = load_vehicle("compact_fwd")
    rng = np.random.default_rng(seed + 17)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.time()
        truth = simulate_wear_year(
            seed, tmp, n_drives=n_drives, drive_s=drive_s, gamma_mm3_per_j=GAMMA, kappa_per_k=KAPPA
        )
        t1 = time.time()
        c_y = truth.c_y_per_rad * np.exp(STAND_IN_LOG_SD * rng.standard_normal(2))
        stand_in = CorneringStiffness(float(c_y[0]), float(c_y[1]), STAND_IN_LOG_SD, "given")
        # each stream validated once, for the lateral fits and the drives' lateral estimates
        frames = [
            (Path(p).name, validate_stream(read_stream(p), vehicle).data)
            for p in truth.stream_paths
        ]
        drives_cornering = cornering_stiffness_from_drives(iter(frames), vehicle)
        fitted = drives_cornering.stiffness
        method = RunSettings().lateral_method
        drive_rows = [drive_lateral(f, vehicle, "dry", method=method) for _, f in frames]
        t2 = time.time()
        tables = {
            "type_prior": wear_evidence_table(truth.stream_paths, vehicle, "compact_fwd"),
            "posterior_stand_in": wear_evidence_table(
                truth.stream_paths, vehicle, "compact_fwd", cornering=stand_in
            ),
        }
        summaries = tables["type_prior"].drop(columns="cornering_stiffness_source")
        summaries = pd.concat([summaries, pd.DataFrame(drive_rows)], axis=1)
        replaced = [
            k
            for k, kind in zip(truth.change_drive_index, truth.change_type, strict=True)
            if kind == "replacement"
        ]
        summaries["tyre_set_id"] = [
            f"set{sum(k >= r for r in replaced)}" for k in range(len(summaries))
        ]
        tables["drive_lateral"], drive_note = with_drive_cornering(summaries)
        if fitted is not None:
            tables["lateral_fit"] = wear_evidence_table(
                truth.stream_paths, vehicle, "compact_fwd", cornering=fitted
            )
        t3 = time.time()
    table = tables["type_prior"]
    history = drive_history(table)
    found = dict(zip(history.changes.index.tolist(), history.changes.change_type, strict=True))
    detection = {}
    for k, kind in zip(truth.change_drive_index, truth.change_type, strict=True):
        hit = [i for i in found if abs(i - k) <= 1]
        detection[kind] = {"found": bool(hit), "classified_as": found[hit[0]] if hit else None}
    false_changes = [i for i in found if all(abs(i - k) > 1 for k in truth.change_drive_index)]
    ev_x = table[["work_x_front_j", "work_x_rear_j"]].to_numpy().sum(axis=0)
    ev_y = {
        name: t[["work_y_front_j", "work_y_rear_j"]].to_numpy().sum(axis=0)
        for name, t in tables.items()
    }
    true_x, true_y = truth.drive_work_j.sum(axis=0), truth.drive_work_y_j.sum(axis=0)
    out = {
        "seed": seed,
        "km": truth.total_km,
        "c_y_true": truth.c_y_per_rad,
        "c_y_stand_in": c_y.tolist(),
        "c_y_lateral_fit": None if fitted is None else fitted.per_axle.tolist(),
        "c_y_lateral_fit_log_sd": None if fitted is None else fitted.log_sd,
        "drive_lateral_note": drive_note,
        "drive_lateral_usable": sum(not r["lateral_reason"] for r in drive_rows),
        "c_y_drive_lateral": [
            float(tables["drive_lateral"][f"cornering_stiffness_{a}_per_rad"].iloc[0])
            for a in ("front", "rear")
        ],
        "lateral_fit_tries": [
            {"drive": drive, "reason": reason} for drive, reason in drives_cornering.tries
        ],
        "true_wear_mm_per_1000km": np.asarray(truth.wear_mm_per_1000km).tolist(),
        "true_g_per_1000km_car_set": float(
            2.0
            * np.sum(truth.wear_mm_per_1000km)
            * GEOM.wear_area_mm2
            * GEOM.rubber_density_g_per_cm3
            / 1000.0
        ),
        "lateral_share_of_true_work": float(true_y.sum() / (true_x.sum() + true_y.sum())),
        "lateral_share_rear": float(true_y[1] / (true_x[1] + true_y[1])),
        "detection": detection,
        "false_changes": len(false_changes),
        "radius_drift_slope_over_truth": _drift_slope_over_truth(
            table, truth, vehicle.wheel_radius_m
        ),
        "evidence_work_over_true": {
            "x_front": float(ev_x[0] / true_x[0]),
            "x_rear": float(ev_x[1] / true_x[1]),
            **{f"y_front_{k}": float(v[0] / true_y[0]) for k, v in ev_y.items()},
            **{f"y_rear_{k}": float(v[1] / true_y[1]) for k, v in ev_y.items()},
        },
        "seconds": {"simulate": t1 - t0, "lateral_fit": t2 - t1, "evidence_tables": t3 - t2},
    }
    for name in SOURCES:
        if name in tables:
            out[name] = _fit_source(tables[name], truth, seed, nuts)
    # Without a usable lateral fit the package's default is the type prior: that year's fit.
    out["lateral_fit"] = out.get("lateral_fit", out["type_prior"])
    # the types the fit took, the readings heard (the type-prior fit's; every source's history
    # has the same changes and readings)
    fitted_types = dict(
        zip(
            out["type_prior"]["tyre_changes"]["drive_index"],
            out["type_prior"]["tyre_changes"]["change_type"],
            strict=True,
        )
    )
    for k, kind in zip(truth.change_drive_index, truth.change_type, strict=True):
        hit = [i for i in fitted_types if abs(i - k) <= 1]
        detection[kind]["fitted_as"] = fitted_types[hit[0]] if hit else None
    return out


def _share(years, source, *path) -> float:
    vals = []
    for r in years:
        x = r[source]
        for p in path:
            x = x[p]
        vals.append(bool(x))
    return sum(vals) / len(vals)


def _median(values: list[float]) -> float | None:
    return float(np.median(values)) if values else None


def _bias_note(se: float | None) -> str:
    if se is None:
        return ""
    return (
        f"median over the years of γ's median / truth - 1; its standard error {se:.3f} "
        "(bootstrap over the years)"
    )


def _summary(years: list[dict]) -> tuple[dict, list[dict]]:
    n = len(years)
    summary: dict = {"years": n, "gamma_true": GAMMA, "kappa_true": KAPPA}
    figures = []
    for source in SOURCES:
        # A fit that did not converge is counted and named, not summarised.
        done = [r for r in years if r[source]["converged"]]
        left_out = {str(r["seed"]): r[source]["diagnostics"]["reasons"] for r in years}
        left_out = {seed: reasons for seed, reasons in left_out.items() if reasons}
        k = len(done)
        g_cov = _share(done, source, "gamma", "covers_truth") if done else None
        hw = _median([r[source]["gamma"]["half_width_rel"] for r in done])
        errors = [r[source]["gamma"]["median"] / GAMMA - 1.0 for r in done]
        bias, bias_se = _median(errors), _bootstrap_se(errors)
        gw_cov = _share(done, source, "gamma_work", "covers_truth") if done else None
        gw_hw = _median([r[source]["gamma_work"]["half_width_rel"] for r in done])
        front = (
            _share(done, source, "wear_mm_per_1000km", "front", "covers_truth") if done else None
        )
        rear = _share(done, source, "wear_mm_per_1000km", "rear", "covers_truth") if done else None
        not_conv = n - k
        summary[source] = {
            "gamma_coverage_90": g_cov,
            "gamma_half_width_one_year": hw,
            "gamma_median_bias": bias,
            "gamma_median_bias_se": bias_se,
            "gamma_work_coverage_90": gw_cov,
            "gamma_work_half_width_one_year": gw_hw,
            "rate_coverage_90_front": front,
            "rate_coverage_90_rear": rear,
            "fits_not_converged": not_conv,
            "not_converged": left_out,
        }
        label = LABELS[source]
        note = (
            f"{k} of {n} simulated years, one fit each with tread readings; "
            f"{not_conv} left out (not converged)"
        )
        kw = {"count": k, "exclusions": left_out}
        figures += [
            figure(
                f"gamma 90% coverage ({label})",
                g_cov,
                target=(">=", 0.8),
                note=note,
                headline=source == HEADLINE,
                **kw,
            ),
            figure(
                f"gamma one-year 90% half-width ({label})",
                hw,
                target=("<=", HALF_WIDTH_TARGET),
                note="relative to the median; ±0.33 before the lateral work and the brake split",
                headline=source == HEADLINE,
                **kw,
            ),
            figure(
                f"gamma median bias ({label})",
                bias,
                target=("abs<=", 0.1),
                note=_bias_note(bias_se),
                **kw,
            ),
            figure(f"gamma*s 90% coverage ({label})", gw_cov, **kw),
            figure(f"gamma*s one-year 90% half-width ({label})", gw_hw, **kw),
            figure(f"front wear-rate 90% coverage ({label})", front, target=(">=", 0.8), **kw),
            figure(f"rear wear-rate 90% coverage ({label})", rear, target=(">=", 0.8), **kw),
            figure(f"wear fits not converged ({label})", not_conv, target=("==", 0), count=n),
        ]
    keys = dict.fromkeys(k for r in years for k in r["evidence_work_over_true"])
    ratios = {
        k: _median(
            [r["evidence_work_over_true"][k] for r in years if k in r["evidence_work_over_true"]]
        )
        for k in keys
    }
    fitted = [r for r in years if r["c_y_lateral_fit"] is not None]
    c_y_over_truth = _median([c / r["c_y_true"] for r in fitted for c in r["c_y_lateral_fit"]])
    summary["lateral_fit_c_y_over_truth_median"] = c_y_over_truth
    slopes = [r["radius_drift_slope_over_truth"] for r in years]
    summary["radius_drift_slope_over_truth"] = {
        "mean": float(np.mean(slopes)),
        "se": float(np.std(slopes, ddof=1) / np.sqrt(len(slopes))) if len(slopes) > 1 else None,
        "min": float(np.min(slopes)),
        "max": float(np.max(slopes)),
    }
    summary["years_without_usable_lateral_fit"] = n - len(fitted)
    summary["evidence_work_over_true_median"] = ratios
    summary["lateral_share_of_true_work_median"] = float(
        np.median([r["lateral_share_of_true_work"] for r in years])
    )
    summary["rotation_found"] = sum(r["detection"]["rotation"]["found"] for r in years) / n
    summary["replacement_found"] = sum(r["detection"]["replacement"]["found"] for r in years) / n
    summary["false_changes_total"] = sum(r["false_changes"] for r in years)

    def typed_right(field: str) -> dict:
        return {
            kind: sum(r["detection"][kind].get(field) == kind for r in years)
            for kind in ("rotation", "replacement")
        }

    right, fitted_right = typed_right("classified_as"), typed_right("fitted_as")
    found = {kind: sum(r["detection"][kind]["found"] for r in years) for kind in right}
    summary["changes_classified_right"] = {"ratio_test": right, "with_readings": fitted_right}
    figures += [
        figure(
            "evidence longitudinal work over true, front",
            ratios["x_front"],
            count=n,
            note=f"WORK_SCALE_LOG_SD = {WORK_SCALE_LOG_SD} carries it",
        ),
        figure("evidence longitudinal work over true, rear", ratios["x_rear"], count=n),
        figure(
            "lateral fit's c_y over the truth, median over axles and years",
            c_y_over_truth,
            count=2 * len(fitted),
            note=f"{n - len(fitted)} of {n} years without a usable lateral fit",
        ),
        figure(
            "evidence lateral work over true, front (c_y from the lateral fit)",
            ratios.get("y_front_lateral_fit"),
            count=len(fitted),
        ),
        figure(
            "evidence lateral work over true, rear (c_y from the lateral fit)",
            ratios.get("y_rear_lateral_fit"),
            count=len(fitted),
        ),
        figure(
            "evidence lateral work over true, front (c_y stand-in)",
            ratios["y_front_posterior_stand_in"],
            count=n,
        ),
        figure(
            "evidence lateral work over true, rear (c_y stand-in)",
            ratios["y_rear_posterior_stand_in"],
            count=n,
        ),
        figure(
            "radius-ratio drift over the true tread loss, mean over years",
            summary["radius_drift_slope_over_truth"]["mean"],
            count=n,
            note=(
                "slope of the evidence's front/rear radius ratio on the true depth difference, "
                "times the radius, per year; standard error "
                f"{summary['radius_drift_slope_over_truth']['se'] or float('nan'):.3f}, range "
                f"{summary['radius_drift_slope_over_truth']['min']:.2f}-"
                f"{summary['radius_drift_slope_over_truth']['max']:.2f}: a year's γ error "
                "follows its slope"
            ),
        ),
        figure("rotation found", summary["rotation_found"], count=n),
        figure("replacement found", summary["replacement_found"], count=n),
        figure("false tyre changes", summary["false_changes_total"], count=n),
    ]
    n_found = sum(found.values())
    for how, typed in (
        ("the radius ratio's test", right),
        ("with the tread readings (what the fit used)", fitted_right),
    ):
        figures.append(
            figure(
                f"found changes of the right type, {how}",
                sum(typed.values()) / max(n_found, 1),
                count=n_found,
                note=f"rotations {typed['rotation']} of {found['rotation']}, replacements "
                f"{typed['replacement']} of {found['replacement']}",
            )
        )
    return summary, figures


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--years", type=int, default=10, help="simulated years (seeds)")
    parser.add_argument("--drives", type=int, default=30, help="logged drives per year")
    parser.add_argument("--drive-s", type=float, default=600.0, help="length of a logged drive")
    parser.add_argument("--samples", type=int, default=800, help="NUTS warm-up and draws")
    parser.add_argument("--jobs", type=int, default=1, help="years simulated and fitted at once")
    args = parser.parse_args(argv)
    nuts = {"num_warmup": args.samples, "num_samples": args.samples, "num_chains": 2}
    seeds = [1000 + y for y in range(args.years)]
    run = functools.partial(run_year, n_drives=args.drives, drive_s=args.drive_s, nuts=nuts)
    years = []
    with contextlib.ExitStack() as stack:
        if args.jobs > 1:
            spawn = multiprocessing.get_context("spawn")
            pool = stack.enter_context(ProcessPoolExecutor(args.jobs, mp_context=spawn))
            results = pool.map(run, seeds)
        else:
            results = map(run, seeds)
        for year in results:
            years.append(year)
            print(str(to_jsonable(year))[:300], flush=True)
    summary, figures = _summary(years)
    headline = summary[HEADLINE]
    payload = {
        # the interface the checks read: γ's own figures of the package's default path
        "gamma_coverage_90": headline["gamma_coverage_90"],
        "gamma_half_width_one_year": headline["gamma_half_width_one_year"],
        "gamma_half_width_target": HALF_WIDTH_TARGET,
        "gamma_half_width_met": (headline["gamma_half_width_one_year"] or np.inf)
        <= HALF_WIDTH_TARGET,
        "gamma_work_coverage_90": headline["gamma_work_coverage_90"],
        "gamma_work_half_width_one_year": headline["gamma_work_half_width_one_year"],
        "summary": summary,
        "years": years,
        "settings": {
            "seeds": [r["seed"] for r in years],
            "drives_per_year": args.drives,
            "drive_s": args.drive_s,
            "sample_rate_hz": 10.0,
            "km_per_year": 15000.0,
            "nuts": nuts,
            "stand_in_log_sd": STAND_IN_LOG_SD,
            "not_run": "drift-only fits and prefix fits (CPU budget of a shared 2-core machine)",
        },
        "machine_note": "shared 2-core CPU machine, other jobs running: timings are indicative",
    }
    write_result("wear_history", to_jsonable(payload), figures=figures)
    print(to_jsonable(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
