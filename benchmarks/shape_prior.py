"""How the prior of the tyre curve's shape exponent moves C_x, with brush and Magic Formula truth.

The default (``"shaped"``) tyre curve has one shape exponent p (p = 1 the brush; a measured Magic
Formula curve is close to p = 2) and every p keeps the slope C_x at zero slip. On one drive
the data inform p only through the curvature at moderate forces, and C_x moves with p: a curve
that is straighter at the start (larger p) fits the same bending data with a lower C_x. So
whatever sets p sets part of C_x. This script measures how much, on the recovery benchmark's
simulated one-hour drives (``tyre_recovery.simulated_observations``), for brush and Magic Formula
truth with ABS:

* the default prior of p (0.5 plus a log-normal of median 1.2, log-sd 0.4) against the previous
  one (1 plus a log-normal of median 0.5, log-sd 1: p ≥ 1, the brush at its bound), a wider one
  of that form (median 0.15, log-sd 2) and a wider one of the default's (median 1, log-sd 0.5);
* p held fixed (a prior of log-sd 0.01) at 1 (the brush model), 1.5, 2.04 and 2.5.

Reported per variant: C_x bias, its Monte Carlo standard error, RMSE, the mean posterior sd,
50/90 % coverage and the mean fitted p. Usage: ``python benchmarks/shape_prior.py [--reps N]``
(default 30 drives per truth). Writes ``benchmarks/results/shape_prior.json``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import jax
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from tyre_recovery import SETTINGS, simulated_observations  # noqa: E402

from tyrebayes import TyrePriors, fit_tyre, load_vehicle  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "shape_prior.json"
# p = p_min + b, b log-normal: (p_min, median of b, log-sd of b).
FREE_PRIORS = {
    "default: 0.5 + LN(1.2, 0.4)": (0.5, 1.2, 0.4),
    "previous: 1 + LN(0.5, 1.0)": (1.0, 0.5, 1.0),
    "1 + LN(0.15, 2.0)": (1.0, 0.15, 2.0),
    "0.5 + LN(1.0, 0.5)": (0.5, 1.0, 0.5),
}
FIXED_SHAPES = (1.0, 1.5, 2.04, 2.5)


def variants() -> dict[str, tuple[str, TyrePriors]]:
    """Name -> (tyre-curve model, priors) of every fit made on each drive."""
    out = {
        name: ("shaped", TyrePriors(curve_shape_min=lo, curve_bend_median=m, curve_bend_log_sd=s))
        for name, (lo, m, s) in FREE_PRIORS.items()
    }
    out["fixed p=1 (brush model)"] = ("brush", TyrePriors())
    for p in FIXED_SHAPES[1:]:
        out[f"fixed p={p}"] = (
            "shaped",
            TyrePriors(curve_shape_min=0.5, curve_bend_median=p - 0.5, curve_bend_log_sd=0.01),
        )
    return out


def summarise(errors: list[dict]) -> dict:
    e = np.array([r["error"] for r in errors])
    return {
        "c_x_bias": float(e.mean()),
        "c_x_bias_se": float(e.std(ddof=1) / np.sqrt(e.size)),
        "c_x_rmse": float(np.sqrt(np.mean(e**2))),
        "c_x_rel_sd_mean": float(np.mean([r["rel_sd"] for r in errors])),
        "c_x_coverage_50": float(np.mean([r["cover50"] for r in errors])),
        "c_x_coverage_90": float(np.mean([r["cover90"] for r in errors])),
        "curve_shape_mean": float(np.mean([r["shape"] for r in errors])),
        "n_converged": len(errors),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=30, help="drives per truth")
    parser.add_argument("--out", default=str(RESULTS))
    args = parser.parse_args()
    vehicle = load_vehicle("compact_fwd")
    pad_to = 1 << int(np.ceil(np.log2(3600 * 4 + 64)))
    settings = [s for s in SETTINGS if s["name"] in ("brush_abs", "magic_formula_abs")]
    fits = variants()
    t0 = time.perf_counter()
    results = {}
    for setting in settings:
        rows = {name: [] for name in fits}
        for seed in range(1000, 1000 + args.reps):
            obs, _, truth, _ = simulated_observations(seed, setting, 3600.0, vehicle, pad_to)
            c_x_true = float(np.mean(truth.c_x))
            for name, (model, priors) in fits.items():
                fit = fit_tyre(obs, method="fast", seed=seed, model=model, priors=priors)
                if not fit.diagnostics.converged:
                    continue
                draws = fit.draws("c_x")
                q05, q25, q75, q95 = np.quantile(draws, [0.05, 0.25, 0.75, 0.95])
                shape = fit.draws("curve_shape").mean() if model == "shaped" else 1.0
                rows[name].append(
                    {
                        "error": float(draws.mean() / c_x_true - 1.0),
                        "rel_sd": float(draws.std() / c_x_true),
                        "cover50": bool(q25 <= c_x_true <= q75),
                        "cover90": bool(q05 <= c_x_true <= q95),
                        "shape": float(shape),
                    }
                )
        results[setting["name"]] = {name: summarise(r) for name, r in rows.items() if r}
        for name, s in results[setting["name"]].items():
            print(
                f"{setting['name']:18s} {name:24s} C_x bias {100 * s['c_x_bias']:+5.2f} % "
                f"(se {100 * s['c_x_bias_se']:.2f}) RMSE {100 * s['c_x_rmse']:.2f} % "
                f"sd {100 * s['c_x_rel_sd_mean']:.2f} % cov50/90 {s['c_x_coverage_50']:.2f}/"
                f"{s['c_x_coverage_90']:.2f} p {s['curve_shape_mean']:.2f}",
                flush=True,
            )
    payload = {
        "description": __doc__.splitlines()[0],
        "drives_per_truth": args.reps,
        "drive_duration_s": 3600.0,
        "method": "fast path (MAP + Laplace), same drives for every variant",
        "wall_time_s": time.perf_counter() - t0,
        "results": results,
    }
    out = write_result("shape_prior", payload, path=args.out)
    print(f"wrote {out} in {payload['wall_time_s']:.0f} s")


if __name__ == "__main__":
    main()
