"""Hierarchical fleet model vs the thesis' OLS line: accuracy, calibration, speed, real data.

Run: ``python benchmarks/fleet_vs_ols.py [--quick]``. Saves ``benchmarks/results/fleet_vs_ols.json``
and ``benchmarks/results/fleet_vs_ols_braking.png``.

1. Out-of-sample accuracy on simulated snow fleets (``tyrebayes.simulate.fleet``, thesis-like:
   60 % winter, 15 % all-season, 25 % summer; no hidden effect) of 26, 100 and 1,000 sets:
   ELPD per set by PSIS-LOO (ArviZ; OLS: exact leave-one-out refits) and on a true held-out
   fleet of 500 sets, RMSE of the predictive mean and 90 % interval coverage on the held-out sets.
2. Timing: NUTS on 26 sets after compilation (target <= 10 s) and SVI on 10,000 sets (<= 60 s).
3. The measured braking data: predictive mu of a typical set of each type (stiffness at the type
   reference, sd 1.5) by surface, from a fit to a simulated 26-set fleet on all four surfaces,
   against the mean decelerations (lower bounds on mu_max) of ``braking_by_tyre_type.csv``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpyro
from _results import write_result  # noqa: E402

numpyro.set_host_device_count(2)

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from _internal import loo as psis_loo  # noqa: E402
from _internal import ols_interval, ols_logpdf, ols_loo_logpdf  # noqa: E402
from _results import save_figure  # noqa: E402

from tyrebayes import SURFACES, TYRE_TYPES, fit_ols  # noqa: E402
from tyrebayes.inference.fleet import (  # noqa: E402
    fit_fleet,
    load_tyre_type_priors,
    measured_braking_bounds,
    predict_friction,
    predictive_draws,
    predictive_logpdf,
)
from tyrebayes.simulate import simulate_fleet  # noqa: E402

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")
N_TEST = 500


def _fit(table, n_sets, seed, quick):
    if n_sets <= 100:
        draws = 300 if quick else 500
        return fit_fleet(table, seed=seed, num_warmup=draws, num_samples=draws, num_chains=2)
    return fit_fleet(table, seed=seed, num_warmup=300, num_samples=300, num_chains=2)


def accuracy_setting(n_sets: int, reps: int, quick: bool) -> dict:
    rows = []
    for rep in range(reps):
        seed = 1000 * n_sets + rep
        train, _ = simulate_fleet(seed, n_sets)
        test, _ = simulate_fleet(seed + 500_000, N_TEST)
        t0 = time.perf_counter()
        fit = _fit(train, n_sets, rep, quick)
        fit_s = time.perf_counter() - t0
        loo = psis_loo(fit.data, var_name="mu")
        k = np.asarray(loo.pareto_k)
        hier_lp = predictive_logpdf(fit, test, seed=rep)
        draws = predictive_draws(fit, test, seed=rep)
        lo, hi = np.quantile(draws, [0.05, 0.95], axis=0)
        y = test["mu"].to_numpy()
        ols = fit_ols(train["c_xr"], train["mu"])
        o_mean, o_lo, o_hi = ols_interval(ols, test["c_xr"].to_numpy(), 0.9)
        rows.append(
            {
                "rep": rep,
                "fit_seconds": fit_s,
                "converged": fit.converged,
                "hier_loo_elpd_per_set": float(loo.elpd) / n_sets,
                "hier_loo_se_per_set": float(loo.se) / n_sets,
                "hier_pareto_k_max": float(k.max()),
                "hier_pareto_k_frac_gt_0.7": float(np.mean(k > 0.7)),
                "ols_loo_elpd_per_set": float(ols_loo_logpdf(train["c_xr"], train["mu"]).mean()),
                "hier_heldout_elpd_per_set": float(hier_lp.mean()),
                "ols_heldout_elpd_per_set": float(
                    ols_logpdf(ols, test["c_xr"].to_numpy(), y).mean()
                ),
                "hier_rmse": float(np.sqrt(np.mean((draws.mean(axis=0) - y) ** 2))),
                "ols_rmse": float(np.sqrt(np.mean((o_mean - y) ** 2))),
                "hier_coverage_90": float(np.mean((y >= lo) & (y <= hi))),
                "ols_coverage_90": float(np.mean((y >= o_lo) & (y <= o_hi))),
                "ols_r2": ols.r2,
            }
        )
    keys = [k for k in rows[0] if k not in ("rep",)]
    mean = {k: float(np.mean([r[k] for r in rows])) for k in keys}
    mean["all_converged"] = all(r["converged"] for r in rows)
    mean["hier_better_loo_every_rep"] = all(
        r["hier_loo_elpd_per_set"] > r["ols_loo_elpd_per_set"] for r in rows
    )
    mean["hier_better_heldout_every_rep"] = all(
        r["hier_heldout_elpd_per_set"] > r["ols_heldout_elpd_per_set"] for r in rows
    )
    return {"n_sets": n_sets, "reps": reps, "n_test": N_TEST, "mean": mean, "per_rep": rows}


def timing(quick: bool) -> dict:
    out = {}
    a, _ = simulate_fleet(1, 26)
    b, _ = simulate_fleet(2, 26)
    t0 = time.perf_counter()
    fit_fleet(a, seed=0)
    first = time.perf_counter() - t0
    times = []
    for key, table in enumerate((b, a) if not quick else (b,)):
        t0 = time.perf_counter()
        fit = fit_fleet(table, seed=key + 1)
        times.append(time.perf_counter() - t0)
    out["nuts_26_sets"] = {
        "settings": "2 chains x (500 warm-up + 500 draws), parallel chains on 2 host devices",
        "first_call_seconds_incl_compile": first,
        "after_compile_seconds": times,
        "converged": fit.converged,
        "target_seconds": 10.0,
    }
    big, _ = simulate_fleet(3, 10_000)
    t0 = time.perf_counter()
    fit = fit_fleet(big, method="svi", seed=0)
    first = time.perf_counter() - t0
    big2, _ = simulate_fleet(4, 10_000)
    t0 = time.perf_counter()
    fit = fit_fleet(big2, method="svi", seed=1)
    second = time.perf_counter() - t0
    post = fit.posterior
    out["svi_10000_sets"] = {
        "settings": "AutoNormal, Adam 0.02, 3000 steps, 500 draws",
        "first_call_seconds_incl_compile": first,
        "second_call_seconds": second,
        "converged": fit.converged,
        "target_seconds": 60.0,
        "snow_a_posterior_mean": {
            t: float(post["a"].sel(surface="snow", tyre_type=t).mean()) for t in TYRE_TYPES
        },
        "snow_a_truth": {"winter": 0.45, "all_season": 0.42, "summer": 0.18},
    }
    return out


def braking_comparison(quick: bool) -> tuple[list[dict], dict]:
    table, _ = simulate_fleet(7, 26, surface=SURFACES)
    fit = fit_fleet(
        table, seed=0, num_warmup=300 if quick else 500, num_samples=300 if quick else 500
    )
    priors = load_tyre_type_priors()
    pred = {}
    for s in SURFACES:
        for i, t in enumerate(TYRE_TYPES):
            draws = predict_friction(fit, float(priors.c_xr_ref[i]), 1.5, t, s, seed=0)
            pred[(s, t)] = draws
    rows = []
    for _, r in measured_braking_bounds().iterrows():
        d = pred[(r.surface, r.tyre_type)]
        lo, med, hi = np.quantile(d, [0.05, 0.5, 0.95])
        rows.append(
            {
                "source": r.source,
                "surface": r.surface,
                "tyre_type": r.tyre_type,
                "measured_deceleration_g": float(r.deceleration_g),
                "bound": r.bound,
                "predicted_median": float(med),
                "predicted_90": [float(lo), float(hi)],
                "p_mu_consistent_with_bound": float(
                    np.mean(d >= r.deceleration_g)
                    if r.bound == "lower"
                    else np.mean(d <= r.deceleration_g / 0.7)
                ),
            }
        )
    _plot_braking(pred, rows)
    return rows, {"converged": fit.converged}


def _plot_braking(pred: dict, rows: list[dict]) -> None:
    fig, axes = plt.subplots(1, 4, figsize=(13, 3.6), sharey=False)
    for ax, s in zip(axes, SURFACES, strict=True):
        for i, t in enumerate(TYRE_TYPES):
            d = pred[(s, t)]
            lo, med, hi = np.quantile(d, [0.05, 0.5, 0.95])
            ax.errorbar(
                i,
                med,
                yerr=[[med - lo], [hi - med]],
                fmt="o",
                color="C0",
                capsize=4,
                label="model 90% predictive" if i == 0 else None,
            )
        for r in rows:
            if r["surface"] != s:
                continue
            i = TYRE_TYPES.index(r["tyre_type"]) + 0.15
            marker = "^" if r["bound"] == "lower" else "v"
            ax.plot(
                i,
                r["measured_deceleration_g"],
                marker,
                color="C3",
                ms=7,
                label=f"measured ({r['bound']} bound)",
            )
        ax.set_xticks(range(3), ["winter", "all-season", "summer"])
        ax.set_title(s)
        ax.set_ylabel("mu_max  /  mean deceleration [g]")
        handles, labels = ax.get_legend_handles_labels()
        uniq = dict(zip(labels, handles, strict=True))
        ax.legend(uniq.values(), uniq.keys(), fontsize=7, loc="best")
    fig.suptitle("Fleet model predictive friction by type vs measured braking decelerations")
    fig.tight_layout()
    save_figure(fig, os.path.join(RESULTS, "fleet_vs_ols_braking.png"), dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="26 and 100 sets, 2 reps each")
    args = parser.parse_args(argv)
    settings = [(26, 2), (100, 2)] if args.quick else [(26, 5), (100, 3), (1000, 2)]
    t_start = time.perf_counter()
    accuracy = [accuracy_setting(n, r, args.quick) for n, r in settings]
    timings = timing(args.quick)
    braking, braking_fit = braking_comparison(args.quick)
    result = {
        "quick": args.quick,
        "accuracy": accuracy,
        "timing": timings,
        "braking_data": {"fit": braking_fit, "rows": braking},
        "total_seconds": time.perf_counter() - t_start,
    }
    write_result("fleet_vs_ols", result, quick=args.quick)
    print(
        "setting  | ELPD/set LOO hier vs OLS | held-out hier vs OLS | RMSE hier/OLS | cov90 h/OLS"
    )
    for a in accuracy:
        m = a["mean"]
        print(
            f"n={a['n_sets']:5d} | {m['hier_loo_elpd_per_set']:7.3f} vs "
            f"{m['ols_loo_elpd_per_set']:7.3f}"
            f"     | {m['hier_heldout_elpd_per_set']:7.3f} vs {m['ols_heldout_elpd_per_set']:7.3f}"
            f" | {m['hier_rmse']:.4f}/{m['ols_rmse']:.4f} | {m['hier_coverage_90']:.3f}/"
            f"{m['ols_coverage_90']:.3f}  (converged {m['all_converged']}, "
            f"fit {m['fit_seconds']:.1f}s, k>0.7 {m['hier_pareto_k_frac_gt_0.7']:.3f})"
        )
    n = timings["nuts_26_sets"]
    s = timings["svi_10000_sets"]
    print(
        f"NUTS 26 sets: first {n['first_call_seconds_incl_compile']:.1f}s, after compile "
        f"{', '.join(f'{x:.1f}' for x in n['after_compile_seconds'])}s (target 10)"
    )
    print(
        f"SVI 10,000 sets: first {s['first_call_seconds_incl_compile']:.1f}s, second "
        f"{s['second_call_seconds']:.1f}s (target 60), converged {s['converged']}"
    )
    print("braking data (typical set of each type):")
    for r in braking:
        print(
            f"  {r['surface']:4s} {r['tyre_type']:10s} measured {r['measured_deceleration_g']:.3f}"
            f" ({r['bound']}) predicted {r['predicted_median']:.3f} "
            f"[{r['predicted_90'][0]:.3f}, {r['predicted_90'][1]:.3f}]  ({r['source']})"
        )
    print(f"total {result['total_seconds']:.0f}s; saved {RESULTS}/fleet_vs_ols.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
