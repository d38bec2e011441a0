"""What the per-block slip offsets do on the package's own simulated drives (and how the drives'
slip errors drift): C_x error with and without them on the recovery benchmark's drives.

The external drives' comparison is ``results/external_drives.json`` (with) against
``results/external_drives_no_blocks.json`` (without, ``slip_drift_median = 0``).

Usage: ``python benchmarks/block_offsets.py [--seeds 1000-1005] [--duration 1200]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import jax
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from tyre_recovery import SETTINGS, simulated_observations  # noqa: E402

from tyrebayes import TyrePriors, fit_tyre, load_vehicle  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "block_offsets.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1000-1005")
    parser.add_argument("--duration", type=float, default=1200.0)
    parser.add_argument("--setting", default="magic_formula_abs")
    args = parser.parse_args()
    lo, hi = (int(x) for x in args.seeds.split("-"))
    setting = next(s for s in SETTINGS if s["name"] == args.setting)
    vehicle = load_vehicle("compact_fwd")
    pad_to = 1 << int(np.ceil(np.log2(args.duration * 4 + 64)))
    variants = {"with_blocks": TyrePriors(), "without_blocks": TyrePriors(slip_drift_median=0.0)}
    rows, t0 = [], time.perf_counter()
    for seed in range(lo, hi + 1):
        obs, _, truth, _ = simulated_observations(seed, setting, args.duration, vehicle, pad_to)
        c_x_true = float(np.mean(truth.c_x))
        row = {"seed": seed, "c_x_true": c_x_true}
        for name, priors in variants.items():
            fit = fit_tyre(obs, method="fast", seed=seed, priors=priors)
            c_x = fit.draws("c_x")
            lo90, hi90 = np.quantile(c_x, [0.05, 0.95])
            row[name] = {
                "c_x_err": float(c_x.mean() / c_x_true - 1),
                "c_x_sd_rel": float(c_x.std() / c_x.mean()),
                "cover_90": bool(lo90 <= c_x_true <= hi90),
                "slip_variance_inflation": float(fit.slip_variance_inflation[0]),
                "adequate": bool(fit.adequacy.adequate),
                "converged": bool(fit.diagnostics.converged),
            }
        rows.append(row)
        print(
            seed,
            {k: round(row[k]["c_x_err"], 3) for k in variants},
            {k: row[k]["slip_variance_inflation"] for k in variants},
            flush=True,
        )
    summary = {
        k: {
            "c_x_err_mean": float(np.mean([r[k]["c_x_err"] for r in rows])),
            "c_x_rmse": float(np.sqrt(np.mean([r[k]["c_x_err"] ** 2 for r in rows]))),
            "cover_90": int(sum(r[k]["cover_90"] for r in rows)),
        }
        for k in variants
    }
    result = {
        "benchmark": "block_offsets",
        "setting": args.setting,
        "drive_duration_s": args.duration,
        "n_drives": len(rows),
        "wall_s": time.perf_counter() - t0,
        "load_avg_1min": os.getloadavg()[0],
        "summary": summary,
        "drives": rows,
    }
    write_result("block_offsets", result, path=RESULTS)
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
