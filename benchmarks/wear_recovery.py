"""Recovery of the abrasability gamma from tread-depth readings and from radius drift alone.

For each replicate one car with known gamma (0.05 mm^3/J, kappa = 0, C_xr = 40 known to 5 %)
is driven through a year of mixed drives (seasonal ambient, 30-110 km/h mean speeds). For each
observation source (``depth``: readings of both axles at 5 evenly spaced odometer values;
``drift``: per-drive relative radius difference front - rear), noise level and mileage, gamma is
fitted with NUTS (:func:`tyrebayes.inference.wear.fit_wear`). Reported per setting: relative
bias of the posterior mean, 50 % and 90 % HDI coverage, median relative half-width of the 90 %
HDI, and the share of replicates whose 90 % HDI lies within +-20 % of the truth; per source and
noise the kilometres needed until the median 90 % HDI half-width is <= 20 % (log-interpolated
between the mileages run).

Run ``python benchmarks/wear_recovery.py [--quick]``; results go to
``benchmarks/results/wear_recovery.json``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import jax
from _results import to_jsonable as _to_jsonable  # noqa: E402
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _internal import hdi  # noqa: E402

from tyrebayes.inference.wear import WearSet, build_wear_data, fit_wear  # noqa: E402
from tyrebayes.physics import Abrasability, DriveWork  # noqa: E402
from tyrebayes.simulate import (  # noqa: E402
    DutyProfile,
    observe_wear,
    seasonal_ambient,
    simulate_drives,
)

RESULTS = Path(__file__).resolve().parent / "results" / "wear_recovery.json"
GAMMA_TRUE = 0.05
C_XR = 40.0
C_XR_SD = 2.0  # 5 %: what a per-tyre stiffness posterior typically gives


def _truncate(work: DriveWork, n: int) -> DriveWork:
    return DriveWork(
        work.distance_km[:n],
        work.ambient_c[:n],
        work.kernel_binned[:n],
        work.grid_c,
        work.volume_mm3[:n],
        work.tyre_temp_mean_c[:n],
    )


def simulate_car(key, max_km: float, profile: DutyProfile) -> DriveWork:
    k1, k2, k3 = jax.random.split(key, 3)
    n = int(max_km / 28.0) + 10  # ~28 km per 30 min drive at a 30-110 km/h mean
    amb = seasonal_ambient(k1, jnp.linspace(0.0, 365.0 * max_km / 15000.0, n))
    speed = jax.random.uniform(k2, (n,), minval=30 / 3.6, maxval=110 / 3.6)
    work = simulate_drives(
        k3, n, amb, C_XR, Abrasability(GAMMA_TRUE), profile, mean_speed_mps=speed
    )
    odo = np.cumsum(np.asarray(work.distance_km))
    n_keep = int(np.searchsorted(odo, max_km)) + 1
    return _truncate(work, min(n_keep, n))


def fit_one(work, source, noise, km, key, warm, samp) -> dict:
    odo = np.cumsum(np.asarray(work.distance_km))
    n = int(np.searchsorted(odo, km)) + 1
    sub = _truncate(work, min(n, odo.size))
    readings = np.linspace(0.0, float(np.sum(np.asarray(sub.distance_km))) - 1e-6, 5)
    obs = observe_wear(
        key,
        sub,
        readings,
        depth_noise_mm=noise if source == "depth" else 0.1,
        radius_noise=noise if source == "drift" else 3e-4,
    )
    data = build_wear_data(
        [WearSet.from_c_xr(sub, obs, "summer", (C_XR, C_XR_SD))],
        use_depth=source == "depth",
        use_drift=source == "drift",
    )
    fit = fit_wear(
        data,
        num_warmup=warm,
        num_samples=samp,
        num_chains=1,
        seed=int(jax.random.randint(key, (), 0, 2**30)),
    )
    g = fit.draws("gamma")[:, 0]
    lo90, hi90 = hdi(g, 0.9)
    lo50, hi50 = hdi(g, 0.5)
    return {
        "rel_bias": float(g.mean() / GAMMA_TRUE - 1),
        "in50": bool(lo50 <= GAMMA_TRUE <= hi50),
        "in90": bool(lo90 <= GAMMA_TRUE <= hi90),
        "rel_halfwidth90": float((hi90 - lo90) / 2 / g.mean()),
        "within20": bool(lo90 >= 0.8 * GAMMA_TRUE and hi90 <= 1.2 * GAMMA_TRUE),
        "divergences": fit.diagnostics.divergences,
    }


def km_to_reach(kms, halfwidths, target=0.2) -> float | None:
    """Log-log interpolation of the mileage where the median half-width reaches ``target``."""
    kms, hw = np.asarray(kms, float), np.asarray(halfwidths, float)
    if hw[0] <= target:
        return float(kms[0])  # already there at the smallest mileage (an upper bound)
    for i in range(1, kms.size):
        if hw[i] <= target:
            x0, x1 = np.log(kms[i - 1]), np.log(kms[i])
            y0, y1 = np.log(hw[i - 1]), np.log(hw[i])
            return float(np.exp(x0 + (np.log(target) - y0) * (x1 - x0) / (y1 - y0)))
    return None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer settings and replicates")
    parser.add_argument("--reps", type=int, default=None, help="replicates per setting")
    args = parser.parse_args(argv)
    if args.quick:
        kms = (1000.0, 3000.0, 10000.0)
        noise = {"depth": (0.1, 0.3), "drift": (3e-4, 1e-3)}
        reps, warm, samp = 3, 150, 200
        profile = DutyProfile(drive_duration_s=1800.0, dt_s=6.0)
    else:
        kms = (1000.0, 3000.0, 10000.0, 20000.0)
        noise = {"depth": (0.05, 0.1, 0.3), "drift": (1e-4, 3e-4, 1e-3)}
        reps, warm, samp = 6, 200, 300
        profile = DutyProfile(drive_duration_s=1800.0, dt_s=4.0)
    reps = args.reps if args.reps is not None else reps
    t0 = time.perf_counter()
    cars = [simulate_car(jax.random.PRNGKey(100 + r), max(kms), profile) for r in range(reps)]
    sim_s = time.perf_counter() - t0
    rows, by_setting = [], {}
    for source, levels in noise.items():
        for lvl in levels:
            for km in kms:
                res = [
                    fit_one(cars[r], source, lvl, km, jax.random.PRNGKey(1000 * r + 7), warm, samp)
                    for r in range(reps)
                ]
                row = {
                    "source": source,
                    "noise": lvl,
                    "km": km,
                    "replicates": reps,
                    "rel_bias_mean": float(np.mean([x["rel_bias"] for x in res])),
                    "coverage50": float(np.mean([x["in50"] for x in res])),
                    "coverage90": float(np.mean([x["in90"] for x in res])),
                    "rel_halfwidth90_median": float(np.median([x["rel_halfwidth90"] for x in res])),
                    "share_within_20pct": float(np.mean([x["within20"] for x in res])),
                    "divergences": int(sum(x["divergences"] for x in res)),
                }
                rows.append(row)
                # every fit compiles new programs; without this ~100 fits exhaust the JIT's
                # code memory ("LLVM compilation error: Cannot allocate memory")
                jax.clear_caches()
                by_setting.setdefault((source, lvl), []).append(row)
                print(
                    f"{source:5s} noise={lvl:<7g} km={km:>7.0f}  bias={row['rel_bias_mean']:+.3f}"
                    f"  cov50={row['coverage50']:.2f} cov90={row['coverage90']:.2f}"
                    f"  halfwidth90={row['rel_halfwidth90_median']:.3f}"
                    f"  within20={row['share_within_20pct']:.2f}",
                    flush=True,
                )
    km_needed = {
        f"{s}@{lvl:g}": km_to_reach(
            [r["km"] for r in rs], [r["rel_halfwidth90_median"] for r in rs]
        )
        for (s, lvl), rs in by_setting.items()
    }
    summary = {
        "coverage50_overall": float(np.mean([r["coverage50"] for r in rows])),
        "coverage90_overall": float(np.mean([r["coverage90"] for r in rows])),
        "rel_bias_overall": float(np.mean([r["rel_bias_mean"] for r in rows])),
    }
    out = {
        "quick": args.quick,
        "gamma_true_mm3_per_j": GAMMA_TRUE,
        "c_xr_prior": [C_XR, C_XR_SD],
        "settings": rows,
        "km_until_90pct_hdi_within_20pct": km_needed,
        "summary": summary,
        "seconds": {"simulate": sim_s, "total": time.perf_counter() - t0},
    }
    write_result("wear_recovery", _to_jsonable(out), quick=args.quick or None)
    print(f"km until median 90% HDI half-width <= 20%: {km_needed}")
    print(f"overall: {summary}; seconds {out['seconds']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
