"""Velocity performance: ISO 3888-2 critical speed, predictive V_max vs thesis Table 6.2.

Run ``python benchmarks/vmax.py [--quick]``; results: ``benchmarks/results/vmax.json`` and
``benchmarks/results/vmax.png``. Reports the time per critical-speed evaluation (after compile),
the time of a vmapped batch of 1,000 parameter draws, predictive V_max per tyre set beside the
measured (interval-censored) values, the driver-free vs extended (driver offset, adaptation, noise)
models by censored log predictive density / PSIS-LOO with SE, the driver-parameter sensitivity,
dV_max/dC_y and dV_max/dμ_y, and a power analysis for the softest vs stiffest set.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import jax
import jax.numpy as jnp
import numpy as np
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

from _results import save_figure  # noqa: E402

from tyrebayes import load_vehicle  # noqa: E402
from tyrebayes.inference import vmax as vm  # noqa: E402
from tyrebayes.physics import (  # noqa: E402
    Driver,
    Tyres,
    critical_speed,
    critical_speed_sensitivity,
    iso3888_2_course,
)

OUT = os.path.join(os.path.dirname(__file__), "results")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    n_draws = 200 if args.quick else 1000
    veh = load_vehicle("compact_fwd")
    course = iso3888_2_course(veh.width_m)
    res: dict = {"vehicle": "compact_fwd", "n_draws_per_set": n_draws}

    # 1. time per evaluation (tolerance 0.05 m/s = 0.18 km/h)
    f = jax.jit(lambda cy, mu: critical_speed(veh, Tyres(cy, mu), course, tol_mps=0.05).v_max_mps)
    f(16.0, 1.0).block_until_ready()
    t = time.perf_counter()
    for i in range(20):
        f(16.0 + 0.01 * i, 1.0).block_until_ready()
    res["ms_per_critical_speed"] = (time.perf_counter() - t) / 20 * 1e3

    # 2. batch of 1,000 draws vmapped (compile excluded)
    cy, mu = vm.lateral_draws(jax.random.PRNGKey(1), 40.0, "all_season", 1000)
    g = jax.jit(
        jax.vmap(lambda a, b: critical_speed(veh, Tyres(a, b), course, tol_mps=0.05).v_max_mps)
    )
    g(cy, mu).block_until_ready()
    t = time.perf_counter()
    g(cy + 1e-6, mu).block_until_ready()
    res["s_per_1000_draws_vmapped"] = time.perf_counter() - t

    # 3. predictive V_max per set
    df = vm.load_table_6_2()
    sets = []
    for i, r in df.iterrows():
        c, m = vm.lateral_draws(
            jax.random.fold_in(jax.random.PRNGKey(0), i), float(r.c_xr), r.tyre_type, n_draws
        )
        v = np.asarray(vm.vmax_draws(veh, c, m))
        sets.append(
            {
                "tyre": r.tyre,
                "type": r.tyre_type,
                "c_xr": float(r.c_xr),
                "measured_pass_kmh": float(r.v_max_kmh),
                "measured_interval_kmh": [
                    float(r.v_max_kmh),
                    float(r.v_max_kmh) + vm.SPEED_STEP_KMH,
                ],
                "pred_mean_kmh": float(np.nanmean(v)),
                "pred_sd_kmh": float(np.nanstd(v)),
                "pred_q05_q95_kmh": np.nanpercentile(v, [5, 95]).tolist(),
                "not_bracketed": sum(vm.range_counts(v).values()),
            }
        )
    res["sets"] = sets
    m_pred = np.array([s["pred_mean_kmh"] for s in sets])
    s_pred = np.array([s["pred_sd_kmh"] for s in sets])
    lo = df["v_max_kmh"].to_numpy(float)
    res["predicted_effect_soft_to_stiff_kmh"] = float(m_pred[-1] - m_pred[0])
    res["measured_slope_kmh_per_cxr"] = float(np.polyfit(df["c_xr"], lo, 1)[0])
    res["predicted_slope_kmh_per_cxr"] = float(np.polyfit(df["c_xr"], m_pred, 1)[0])

    # 4. driver-free vs extended model
    ll0 = np.asarray(
        vm.censored_loglik(
            jnp.asarray(lo),
            vm.SPEED_STEP_KMH,
            jnp.asarray(m_pred),
            jnp.sqrt(jnp.asarray(s_pred) ** 2 + vm.REPEATABILITY_KMH**2),
        )
    )
    res["driver_free"] = {
        "elpd": float(ll0.sum()),
        "se": float(np.sqrt(len(ll0) * ll0.var())),
        "pointwise": ll0.tolist(),
    }
    fit = vm.fit_extended(lo, m_pred, s_pred, seed=0, num_samples=1000)
    post = {k: fit.draws(k) for k in ("delta_kmh", "adaptation", "sigma_driver_kmh")}
    loo = vm.psis_loo(vm.pointwise_log_lik(fit))
    diff = np.array(loo["pointwise"]) - ll0
    res["extended"] = {
        "elpd_loo": loo["elpd_loo"],
        "se": loo["se"],
        "pareto_k_max": loo["pareto_k_max"],
        "delta_kmh_mean_sd": [float(post["delta_kmh"].mean()), float(post["delta_kmh"].std())],
        "adaptation_mean_sd": [float(post["adaptation"].mean()), float(post["adaptation"].std())],
        "sigma_driver_kmh_mean_sd": [
            float(post["sigma_driver_kmh"].mean()),
            float(post["sigma_driver_kmh"].std()),
        ],
        "divergences": fit.diagnostics.divergences,
    }
    res["elpd_gain"] = {"diff": float(diff.sum()), "se": float(np.sqrt(len(diff) * diff.var()))}

    # 5. driver sensitivity of the simulation itself (same tyre, C_y 16, mu_y 0.95)
    drv = {}
    for p, rs in [(0.5, 0.05), (0.5, 0.15), (0.7, 0.15), (0.35, 0.05)]:
        cs = critical_speed(veh, Tyres(16.0, 0.95), course, Driver(p, rs), tol_mps=0.05)
        drv[f"preview{p}_reaction{rs}"] = float(cs.v_max_mps) * 3.6
    res["driver_sensitivity_vmax_kmh"] = drv
    sens = critical_speed_sensitivity(veh, Tyres(16.0, 0.95), course)
    res["sensitivity"] = {
        "method": "implicit differentiation of the footprint margin (jax.grad)",
        "dv_dc_y_kmh_per_unit": float(sens["dv_dc_y"]) * 3.6,
        "dv_dmu_y_kmh_per_unit": float(sens["dv_dmu_y"]) * 3.6,
    }
    h = 0.5
    fd = [
        (float(f(16.0 + h, 0.95)) - float(f(16.0 - h, 0.95))) / (2 * h) * 3.6,
        (float(f(16.0, 0.95 + 0.03)) - float(f(16.0, 0.95 - 0.03))) / 0.06 * 3.6,
    ]
    res["sensitivity"]["finite_difference_bisection_kmh"] = {"dv_dc_y": fd[0], "dv_dmu_y": fd[1]}

    # 6. power: predicted soft-vs-stiff difference, noise = posterior driver noise
    sig = float(np.median(post["sigma_driver_kmh"]))
    res["power"] = {
        "delta_kmh": res["predicted_effect_soft_to_stiff_kmh"],
        "sigma_kmh": sig,
        "table": vm.power_table(res["predicted_effect_soft_to_stiff_kmh"], sig, n_mc=20000),
        "table_half_effect": vm.power_table(
            0.5 * res["predicted_effect_soft_to_stiff_kmh"], sig, n_mc=20000
        ),
    }

    _plot(df, sets)
    write_result("vmax", res, quick=args.quick or None)
    print(json.dumps({k: v for k, v in res.items() if k not in ("sets", "power")}, indent=1))
    for s in sets:
        print(
            f"{s['tyre']:28s} C_xr {s['c_xr']:4.0f}  measured [{s['measured_pass_kmh']:.0f}, "
            f"{s['measured_pass_kmh'] + 10:.0f})  predicted {s['pred_mean_kmh']:.1f}"
            f" ± {s['pred_sd_kmh']:.1f}"
        )
    for key in ("table", "table_half_effect"):
        print(
            key,
            [(r["step_kmh"], r["sessions"], round(r["p_resolve"], 3)) for r in res["power"][key]],
        )


def _plot(df, sets) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    x = df["c_xr"].to_numpy(float)
    for xi, s in zip(x, sets, strict=True):
        ax.plot([xi, xi], s["measured_interval_kmh"], color="k", lw=6, alpha=0.3)
        ax.errorbar(
            xi + 0.6,
            s["pred_mean_kmh"],
            yerr=[
                [s["pred_mean_kmh"] - s["pred_q05_q95_kmh"][0]],
                [s["pred_q05_q95_kmh"][1] - s["pred_mean_kmh"]],
            ],
            fmt="o",
            color="C0",
        )
    ax.plot([], [], color="k", lw=6, alpha=0.3, label="measured interval [pass, pass+10)")
    ax.plot([], [], "o", color="C0", label="driver-free prediction (90%)")
    ax.set_xlabel("C_xr [-]")
    ax.set_ylabel("V_max [km/h]")
    ax.legend(fontsize=8)
    ax.set_title("ISO 3888-2 critical speed, compact_fwd")
    save_figure(fig, os.path.join(OUT, "vmax.png"), dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
