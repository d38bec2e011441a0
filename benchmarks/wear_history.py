"""Tread wear from a car's own drive history: recovery of γ from the written stream files alone.

Per simulated year (:func:`tyrebayes.simulate.wear_history.simulate_wear_year`: compact FWD car,
summer tyres, γ = 0.04 mm³/J, κ = 0.02 /K, 40 logged drives of 600 s at 10 Hz, each standing for
the distance to the next odometer reading, 15,000 km a year, a rotation at drive 18 and a
replacement at drive 32, tread readings every 5,000 km) the pipeline reads only the stream files
(:func:`tyrebayes.streams.wear_evidence.wear_evidence_table`), builds the history
(:func:`tyrebayes.inference.wear.drive_history`: tyre changes detected) and fits γ and κ
(:func:`tyrebayes.inference.wear.fit_wear_history`, NUTS) with and without the readings.

Reported: coverage of the true γ by the 90 % HDI (target ≥ 80 % of years); detection of the
rotation and the replacement (within one drive) and their classification; false changes; the
ratio of the evidence's friction work to the simulator's true work (what biases γ); and, with
radius drift only, the kilometres after which the 90 % HDI of γ lies within ±20 % of its median
(prefix fits of the first years).

Run ``python benchmarks/wear_history.py [--years 20] [--prefix-years 3] [--resume]``; results go to
``benchmarks/results/wear_history.json``. Timings are taken on a machine shared with other jobs.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import tempfile
import time
from pathlib import Path

import jax
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from tyrebayes._domain import load_vehicle  # noqa: E402
from tyrebayes._io import to_jsonable  # noqa: E402
from tyrebayes.inference.result import hdi  # noqa: E402
from tyrebayes.inference.wear.history import drive_history, tread_readings  # noqa: E402
from tyrebayes.inference.wear.history_fit import fit_wear_history  # noqa: E402
from tyrebayes.simulate.wear_history import simulate_wear_year  # noqa: E402
from tyrebayes.streams.wear_evidence import wear_evidence_table  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "wear_history.json"
PREFIX_FRACTIONS = (0.25, 0.5, 0.75, 1.0)
NUTS = {"num_warmup": 500, "num_samples": 500, "num_chains": 2}  # as fit-wear


def _gamma_summary(fit, truth: float) -> dict:
    g = fit.draws("gamma")
    gw = fit.draws("gamma_work")
    lo, hi = hdi(g, 0.9)
    med = float(np.median(g))
    return {
        "median": med,
        "hdi_90": [float(lo), float(hi)],
        "covers_truth": bool(lo <= truth <= hi),
        "half_width_rel": float((hi - lo) / 2 / med),
        "converged": bool(fit.converged),
        "gamma_work_median": float(np.median(gw)),
        "gamma_work_covers_truth": bool(hdi(gw, 0.9)[0] <= truth <= hdi(gw, 0.9)[1]),
    }


def run_year(seed: int, prefix: bool) -> dict:
    vehicle = load_vehicle("compact_fwd")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.time()
        truth = simulate_wear_year(seed, tmp)
        t1 = time.time()
        table = wear_evidence_table(truth.stream_paths, vehicle, "compact_fwd")
        t2 = time.time()
    history = drive_history(table)
    readings = tread_readings(truth.readings)
    found = dict(zip(history.changes.index.tolist(), history.changes.kind, strict=True))
    detection = {}
    for k, kind in zip(truth.change_drive_index, truth.change_kind, strict=True):
        hit = [i for i in found if abs(i - k) <= 1]
        detection[kind] = {
            "found": bool(hit),
            "classified_as": found[hit[0]] if hit else None,
        }
    false_changes = [i for i in found if all(abs(i - k) > 1 for k in truth.change_drive_index)]
    work_ratio = table[["work_x_front_j", "work_x_rear_j"]].to_numpy() / truth.drive_work_j
    out = {
        "seed": seed,
        "km": truth.total_km,
        "detection": detection,
        "false_changes": len(false_changes),
        "evidence_work_over_true": {
            "front_median": float(np.median(work_ratio[:, 0])),
            "rear_median": float(np.median(work_ratio[:, 1])),
            "front_total": float(table["work_x_front_j"].sum() / truth.drive_work_j[:, 0].sum()),
        },
        "seconds": {"simulate": t1 - t0, "evidence": t2 - t1},
    }
    t3 = time.time()
    out["with_readings"] = _gamma_summary(
        fit_wear_history(history, readings, seed=seed, **NUTS), truth.gamma_mm3_per_j
    )
    out["drift_only"] = _gamma_summary(
        fit_wear_history(history, None, seed=seed, **NUTS), truth.gamma_mm3_per_j
    )
    out["seconds"]["two_fits"] = time.time() - t3
    if prefix:
        rows = []
        for frac in PREFIX_FRACTIONS[:-1]:
            n = int(round(frac * len(table)))
            sub = drive_history(table.iloc[:n].reset_index(drop=True))
            s = _gamma_summary(
                fit_wear_history(sub, None, seed=seed, **NUTS), truth.gamma_mm3_per_j
            )
            rows.append({"drives": n, "km": sub.total_km, **s})
        rows.append({"drives": len(table), "km": history.total_km, **out["drift_only"]})
        out["drift_only_prefix"] = rows
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--years", type=int, default=20, help="simulated years (issue: 20)")
    parser.add_argument("--prefix-years", type=int, default=3, help="years with prefix fits")
    parser.add_argument(
        "--resume",
        action="store_true",
        help="keep the years already in the results file and run the rest (same seeds)",
    )
    args = parser.parse_args(argv)
    start = time.time()
    years = []
    if args.resume and RESULTS.exists():
        previous = json.loads(RESULTS.read_text())
        years = previous["years"]
        start -= previous["seconds_total"]
    for y in range(len(years), args.years):
        years.append(run_year(1000 + y, y < args.prefix_years))
        print(json.dumps(to_jsonable(years[-1]))[:400], flush=True)
        # written after every year: an interrupted run leaves the years it finished
        _write(years, args, start)
    print(json.dumps(to_jsonable(_write(years, args, start)["summary"]), indent=2))
    return 0


def _write(years: list[dict], args, start: float) -> dict:
    n = len(years)

    def share(key):
        return sum(r[key]["covers_truth"] for r in years) / n

    km_20 = []
    for r in years:
        rows = r.get("drift_only_prefix")
        if rows:
            ok = [row["km"] for row in rows if row["half_width_rel"] <= 0.2]
            km_20.append(ok[0] if ok else None)
    summary = {
        "years": n,
        "years_requested": args.years,
        "gamma_true": 0.04,
        "kappa_true": 0.02,
        "coverage_90_with_readings": share("with_readings"),
        "coverage_90_drift_only": share("drift_only"),
        "coverage_target": 0.8,
        "rotation_found": sum(r["detection"]["rotation"]["found"] for r in years) / n,
        "rotation_classified": sum(
            r["detection"]["rotation"]["classified_as"] == "rotation" for r in years
        )
        / n,
        "replacement_found": sum(r["detection"]["replacement"]["found"] for r in years) / n,
        "replacement_classified": sum(
            r["detection"]["replacement"]["classified_as"] == "replacement" for r in years
        )
        / n,
        "false_changes_total": sum(r["false_changes"] for r in years),
        "median_gamma_with_readings": float(
            np.median([r["with_readings"]["median"] for r in years])
        ),
        "median_gamma_drift_only": float(np.median([r["drift_only"]["median"] for r in years])),
        "median_half_width_rel_drift_only": float(
            np.median([r["drift_only"]["half_width_rel"] for r in years])
        ),
        "evidence_work_over_true_front_median": float(
            np.median([r["evidence_work_over_true"]["front_total"] for r in years])
        ),
        "converged_fits": sum(
            r["with_readings"]["converged"] + r["drift_only"]["converged"] for r in years
        ),
        "km_to_20pct_drift_only_per_prefix_year": km_20,
        "prefix_fractions": PREFIX_FRACTIONS,
    }
    out = {
        "summary": summary,
        "years": years,
        "settings": {
            "drives_per_year": 40,
            "drive_s": 600.0,
            "sample_rate_hz": 10.0,
            "km_per_year": 15000.0,
            "nuts": NUTS,
            "full_setting": "--years 20",
            "run_argv": sys.argv[1:],
        },
        "seconds_total": time.time() - start,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "machine": "shared 2-core CPU machine, other jobs running: timings are indicative",
    }
    write_result("wear_history", to_jsonable(out), path=RESULTS)
    return out


if __name__ == "__main__":
    sys.exit(main())
