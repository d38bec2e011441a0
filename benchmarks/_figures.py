"""The figures of each benchmark's result, read from its JSON: what the docs and README show.

A result written by :func:`_results.write_result` with ``figures=`` carries its figures itself.
For the results of scripts that do not pass them (and the results written before the shared
writer existed), :data:`EXTRACTORS` reads the same figures from the benchmark's own payload, so
every number the docs print comes from a file in ``benchmarks/results/`` and none is typed by
hand. :func:`figures` gives a result's figures either way.

Targets are the ones the issues set; a figure without one is context for a reader.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

try:  # imported as benchmarks._figures (the docs' generator) or as _figures (a script)
    from ._results import RESULTS, figure
except ImportError:  # pragma: no cover
    from _results import RESULTS, figure

Result = dict[str, Any]
F = figure


def _pct(x: float | None) -> float | None:
    return None if x is None else 100.0 * x


def _external_drives(r: Result) -> list[dict]:
    d = r["pooled"]["default"]
    n = d["n_drives"]
    excl = [f"{k}: did not converge" for k in d["not_converged"]]
    return [
        F(
            "C_x median error, 16 independent drives",
            _pct(d["c_x_median_err"]),
            unit="%",
            target=("abs<=", 3.0),
            count=n,
            exclusions=excl,
            headline=True,
        ),
        F(
            "C_x mean absolute error",
            _pct(d["c_x_mean_abs_err"]),
            unit="%",
            target=("<=", 5.0),
            count=n,
            exclusions=excl,
        ),
        F(
            "C_x 90 % interval covers the truth (drives)",
            d["c_x_cover_90"],
            target=(">=", 13),
            count=n,
            exclusions=excl,
            headline=True,
            note=f"50 % interval: {d['c_x_cover_50']} of {n}",
        ),
        F(
            "μ_max mean absolute error, drives with ABS",
            _pct(d["mu_mean_abs_err"]),
            unit="%",
            target=("<=", 5.0),
            count=d["mu_drives_with_abs"],
            note=f"largest {_pct(d['mu_max_abs_err']):.1f} %",
        ),
        F(
            "μ_max 90 % coverage, drives with ABS",
            d["mu_cover_90"] / d["mu_drives_with_abs"],
            target=(">=", 0.8),
            count=d["mu_drives_with_abs"],
        ),
        F(
            "drives without ABS claiming μ_max observed",
            d["mu_false_claims"],
            target=("==", 0),
            count=n - d["mu_drives_with_abs"],
        ),
        F("fits flagged inadequate", d["n_inadequate"], count=n),
        F(
            "stated / actual window noise, force (median)",
            r["noise_ratio_median"]["force"],
            target=("in", [0.8, 1.25]),
            count=n,
            note="'actual' counts the truth's fast content the wheel speeds do not carry",
        ),
        F(
            "stated / actual window noise, slip (median)",
            r["noise_ratio_median"]["slip"],
            target=("in", [0.8, 1.25]),
            count=n,
        ),
        F(
            "thesis' brush model: C_x median error",
            _pct(r["pooled"]["brush"]["c_x_median_err"]),
            unit="%",
            count=n,
        ),
        F(
            "OLS of force on slip: C_x median error",
            _pct(r["ols_c_x_median_err"]),
            unit="%",
            count=n,
        ),
    ]


def _band(centre: float, tol: float) -> list[float]:
    return [round(centre - tol, 6), round(centre + tol, 6)]


def _tyre_recovery(r: Result) -> list[dict]:
    out = []
    tol = r.get("targets", {}).get("coverage_tolerance", 0.05)
    for name, res in r["results"].items():
        s = res["summary"]
        n = s["n_converged"]
        excl = [f"{s['n_not_converged']} not converged"] if s["n_not_converged"] else []
        if s.get("n_streams_rejected_by_validation"):
            excl.append(f"{s['n_streams_rejected_by_validation']} streams rejected and replaced")
        head = name == "magic_formula_abs"
        out += [
            F(
                f"{name}: C_x bias",
                _pct(s["c_x_posterior"]["bias"]),
                unit="%",
                count=n,
                exclusions=excl,
                note=f"RMSE {_pct(s['c_x_posterior']['rmse']):.1f} %",
            ),
            F(
                f"{name}: C_x 90 % coverage",
                s["c_x_coverage_90"],
                target=("in", _band(0.9, tol)),
                count=n,
                headline=head,
            ),
            F(
                f"{name}: C_x 50 % coverage",
                s["c_x_coverage_50"],
                target=("in", _band(0.5, tol)),
                count=n,
                headline=head,
            ),
        ]
        if s.get("mu_posterior", {}).get("bias") is not None:
            out.append(
                F(
                    f"{name}: μ_max bias",
                    _pct(s["mu_posterior"]["bias"]),
                    unit="%",
                    count=s["n_with_abs_windows"],
                    note=f"90 % coverage {s['mu_coverage_90']:.2f}",
                )
            )
    return out


def _identification(r: Result) -> list[dict]:
    cases = r["cases"]
    bad = [c for c in cases if c["case"] not in ("e00", "e00_first_60s")]
    return [
        F(
            "drives that cannot measure C_x or contradict their label: flagged",
            sum(not c["adequate"] for c in bad),
            target=("==", len(bad)),
            count=len(bad),
            headline=True,
        ),
        F(
            "sound drives flagged",
            sum(not c["adequate"] for c in cases if c not in bad),
            target=("==", 0),
            count=len(cases) - len(bad),
        ),
    ]


def _online_agreement(r: Result) -> list[dict]:
    a = r["pooled"]["all"]
    return [
        F(
            "online C_x agrees with the batch posterior after 10 min",
            a["agreement_share"],
            target=(">=", 0.9),
            count=a["n_drives"],
            headline=True,
        ),
        F(
            "online 90 % interval covers the truth (drive-minutes), pooled",
            a["online_coverage_90_reported"],
            target=("in", [0.85, 0.95]),
            count=a["online_coverage_90_reported_n"],
            headline=True,
            note="too wide on the external drives",
        ),
        *[
            F(
                f"online 90 % coverage, {k}",
                r["pooled"][k]["online_coverage_90_reported"],
                target=("in", [0.85, 0.95]),
                count=r["pooled"][k]["online_coverage_90_reported_n"],
            )
            for k in ("simulated", "external")
        ],
        F(
            "minutes to a useful estimate (median)",
            a["online_time_to_useful"]["median_min"],
            unit="min",
            count=a["online_time_to_useful"]["n"],
        ),
        F(
            "linear-slip EKF: 90 % interval covers the truth",
            a["ekf_coverage_90_all_minutes"],
            count=a["n_drives"],
        ),
        F(
            "alarms on drives without a change",
            a["n_alarms_total"],
            target=("==", 0),
            count=a["n_drives"],
        ),
    ]


def _online_change(r: Result) -> list[dict]:
    d = r["detection"]
    fa = r["false_alarms_model_windows"]
    return [
        F(
            "20 % C_xr swaps found within 5 min",
            d["detected_within_5min_share"],
            target=(">=", d["target_share"]),
            count=d["n_swaps"],
            headline=True,
            note=f"median delay {d['delay_median_s']:.0f} s",
        ),
        F(
            "false alarms per 100 h, windows drawn from the model",
            fa["per_100_hours"],
            target=("<=", fa["target_per_100_hours"]),
            count=fa["drive_starts"],
            headline=True,
        ),
        F(
            "false alarms, same tyre on both drives",
            r["controls_same_tyre"]["n_false_alarms"],
            target=("==", 0),
            count=r["controls_same_tyre"]["n_pairs"],
        ),
    ]


def _online_speed(r: Result) -> list[dict]:
    out = []
    for row in r["single_car"]:
        out.append(
            F(
                f"one car-hour, {row['kind']}, {row['max_step_s']:.0f} s steps",
                1000.0 * row["car_hour_s"],
                unit="ms",
                target=("<=", 1000.0 * row["target_s"]),
                headline=row["kind"] == "magic" and row["max_step_s"] == 30.0,
                note="one pinned core, after compilation, median",
            )
        )
    return out + _online_speed_fleet(r.get("vmapped_fleet", {}))


def _online_outliers(r: Result) -> list[dict]:
    p = r["pooled"]
    return [
        F(
            f"{k.replace('_', ', ')}: false alarms",
            p[k]["runs_with_alarms"],
            count=p[k]["n"],
            note=f"C_x error median {_pct(p[k]['c_x_abs_rel_error_end_median']):.1f} %, "
            f"90 % interval covers {p[k]['covered_end']} of {p[k]['n']}",
        )
        for k in p
    ]


def _discovery(r: Result) -> list[dict]:
    t = r["targets"]
    pa = t["power_aged_26_sets"]
    ph = t["power_half_aged_26_sets"]
    return [
        F(
            "power at the thesis' aged-tyre effect, 26 sets",
            min(v["value"] for v in pa.values()),
            target=(">=", t["power_aged_target"]),
            count=sum(v["of"] for v in pa.values()),
            headline=True,
        ),
        F(
            "power at half that effect, 26 sets",
            min(v["value"] for v in ph.values()),
            target=(">=", t["power_half_target"]),
            count=sum(v["of"] for v in ph.values()),
        ),
        F(
            "false-discovery rate, worst of 20 settings",
            t["fdr_max"],
            target=("<=", t["fdr_target"]),
            count=len(r["settings"]),
            headline=True,
            note="each setting's estimate within 1.3 Monte Carlo SE of 0.05",
        ),
        F("findings with an ELPD gain ≤ 0", t["nonpositive_gain_findings"], target=("==", 0)),
        F(
            "criticize of a 26-row table, command",
            r["timing_26_rows"]["cli_seconds"],
            unit="s",
            target=("<=", r["timing_26_rows"]["target_seconds"]),
        ),
    ]


def _discovery_more_null(r: Result) -> list[dict]:
    return [
        F(
            f"FDR, {s['n_decoys']} decoys, {s['noise']} noise",
            s["fdr"]["value"],
            target=("<=", 0.05),
            count=s["fdr"].get("of"),
        )
        for s in r["settings"]
    ]


def _discovery_tread(r: Result) -> list[dict]:
    return [
        F("tread effect found (tables)", r["found_tread"], count=r["n_tables"]),
        F("false findings", r["false_findings"], target=("==", 0), count=r["n_tables"]),
    ]


def _fleet_vs_ols(r: Result) -> list[dict]:
    out = []
    for a in r["accuracy"]:
        m = a["mean"]
        out.append(
            F(
                f"held-out ELPD per set, {a['n_sets']} sets: hierarchical − OLS",
                m["hier_heldout_elpd_per_set"] - m["ols_heldout_elpd_per_set"],
                target=(">", 0.0),
                count=a["reps"],
                headline=a["n_sets"] == 26,
                note=f"RMSE {m['hier_rmse']:.3f} against {m['ols_rmse']:.3f}; "
                f"90 % coverage {m['hier_coverage_90']:.2f}",
            )
        )
    return out


def _fleet_nuts(r: Result) -> list[dict]:
    d = r["defaults"]
    return [
        F(
            "fleet NUTS fits converged at the defaults",
            d["n_converged"] / d["n_fits"],
            target=("==", 1.0),
            count=d["n_fits"],
        ),
        F(
            "refit on new data of the same shape",
            d["refit_seconds_median"],
            unit="s",
            note=f"first fit {d['first_fit_seconds']:.1f} s",
        ),
    ]


def _fleet_run(r: Result) -> list[dict]:
    h = r["drive_hours_per_core_hour"]
    c = r["per_drive_hour_cpu_seconds"]
    n = r["size"]["drives"]
    return [
        F(
            "drive-hours per core-hour, 1 worker on one core",
            h["one_worker_one_core"],
            target=(">=", h["target"]),
            count=n,
            headline=True,
        ),
        F(
            "drive-hours per core-hour, 2 workers on two cores",
            h["two_workers"],
            target=(">=", h["target"]),
            count=n,
        ),
        F(
            "CPU s per drive-hour, drive stage + fits (warm loop)",
            c["drive_stage"] + c["tyre_set_fit_fast"],
            unit="s",
            target=("<=", 0.72),
            count=n,
        ),
        F(
            "scaling from 1 to 2 workers",
            r["scaling_efficiency_1_to_2"],
            target=(">=", r["scaling_target"]),
        ),
        F(
            "peak memory per worker",
            r["peak_rss_mb_per_worker_max"],
            unit="MB",
            target=("<=", r["peak_target_mb"]),
        ),
    ]


def _tyre_speed(r: Result) -> list[dict]:
    t = r["targets"]
    f = r["fast_one_hour"]["after_compilation"]
    out = [
        F(
            "fast fit of a one-hour drive, after compilation",
            f["wall_s"],
            unit="s",
            target=("<=", t["fast_after_compile_s"]),
            headline=True,
        ),
        F(
            "peak RSS over the one-hour stages",
            r["peak_rss_mb_one_hour_stages"],
            unit="MB",
            target=("<=", t["peak_mb"]),
            headline=True,
        ),
        F("peak RSS of the process, ten-hour stage included", r["peak_rss_mb"], unit="MB"),
    ]
    if "nuts_one_hour" in r:
        out.append(
            F(
                "NUTS 4 × 1,000 draws, one-hour drive",
                r["nuts_one_hour"]["wall_s"],
                unit="s",
                target=("<=", t["nuts_s"]),
            )
        )
    if "fast_ten_hours" in r:
        out.append(
            F(
                "ten one-hour drives stacked / one",
                r["fast_ten_hours"]["ratio_to_one_hour_after_compilation"],
                target=("<=", t["ten_hour_ratio"]),
            )
        )
    return out


def _fit_memory(r: Result) -> list[dict]:
    return [
        F(
            f"fit-tyre --method {f['method']}, {f['cache']} cache: peak RSS",
            f["peak_rss_mb"],
            unit="MB",
            target=("<=", r["target_peak_mb"]),
        )
        for f in r["fits"]
    ]


def _wear_history(r: Result) -> list[dict]:
    s = r["summary"]
    n = s["years"]
    return [
        F(
            "γ inside its 90 % interval, with readings",
            s["coverage_90_with_readings"],
            target=(">=", s["coverage_target"]),
            count=n,
            headline=True,
        ),
        F(
            "γ inside its 90 % interval, radius drift only",
            s["coverage_90_drift_only"],
            target=(">=", s["coverage_target"]),
            count=n,
        ),
        F(
            "rotation found / classified right",
            s["rotation_classified"],
            count=n,
            note=f"found {s['rotation_found']:.2f}",
        ),
        F("replacement classified right", s["replacement_classified"], count=n),
        F("false tyre changes", s["false_changes_total"], target=("==", 0), count=n),
        F(
            "γ interval half-width after a year, drift only",
            _pct(s["median_half_width_rel_drift_only"]),
            unit="%",
            target=("<=", 20.0),
            count=n,
        ),
        F(
            "fits converged",
            s["converged_fits"],
            count=2 * n,
            note="the coverage counts every year",
        ),
    ]


def _wear_thesis(r: Result) -> list[dict]:
    h = r["extension"]["heldout"]
    diag = r["extension"]["diagnostics"]
    return [
        F(
            "held-out ELPD gain of the temperature-dependent abrasability",
            h["elpd_diff_extended_minus_baseline"],
            target=(">", 0.0),
            count=h["n_readings"],
            headline=True,
            note=f"± {h['se_diff']:.1f}; both NUTS fits converged: "
            f"{all(d['converged'] for d in diag.values())}",
        ),
        F(
            "the thesis' wear model ranks soft compounds above stiff ones (the known effect)",
            r["what_it_gets_wrong"]["thesis_model_ordering_correct"],
            note="the reproduced failure that the extension fixes",
        ),
    ]


def _wear_recovery(r: Result) -> list[dict]:
    k = r["km_until_90pct_hdi_within_20pct"]
    return [
        F(f"km until γ's 90 % interval is within ±20 %, {key}", v, unit="km")
        for key, v in k.items()
    ] + [
        F(
            "γ 90 % coverage, all settings",
            r["summary"]["coverage90_overall"],
        )
    ]


def _vmax(r: Result) -> list[dict]:
    return [
        F("one critical-speed bisection", r["ms_per_critical_speed"], unit="ms"),
        F(
            "held-out ELPD gain of the driver-offset model",
            r["elpd_gain"]["diff"],
            target=(">", 0.0),
            headline=True,
            note=f"± {r['elpd_gain']['se']:.1f}",
        ),
    ]


def _real_log_fit(r: Result) -> list[dict]:
    s = r["summary"]
    d = s["diagnostics"]
    return [
        F(
            "real RAV4 log: C_x posterior mean",
            s["c_x"]["mean"],
            headline=True,
            note=f"sd {s['c_x']['sd']:.1f}, 90 % HDI {s['c_x']['hdi_90'][0]:.1f}–"
            f"{s['c_x']['hdi_90'][1]:.1f}; 60 s, no truth",
        ),
        F("R-hat (largest)", d["r_hat_max"], target=("<=", 1.02)),
        F("fit adequate", s["adequate"], target=("==", True)),
    ]


def _shape_prior(r: Result) -> list[dict]:
    out = []
    for truth, variants in r["results"].items():
        for prior, s in variants.items():
            out.append(
                F(
                    f"{truth}, prior {prior}: C_x bias",
                    _pct(s["c_x_bias"]),
                    unit="%",
                    count=s["n_converged"],
                    note=f"90 % coverage {s['c_x_coverage_90']:.2f}",
                )
            )
    return out


def _block_offsets(r: Result) -> list[dict]:
    n = r["n_drives"]
    return [
        F(
            f"C_x RMSE {k.replace('_', ' ')}",
            _pct(s["c_x_rmse"]),
            unit="%",
            count=n,
            note=f"90 % interval covers {s['cover_90']} of {n}",
        )
        for k, s in r["summary"].items()
    ]


def _stored_program(r: Result) -> list[dict]:
    runs = r["runs"]
    return [
        F(
            f"first fit in a new process, {k.replace('_', ' ')} cache",
            v["first_fit_s"],
            unit="s",
            note=f"second fit {v['second_fit_s']:.2f} s",
        )
        for k, v in runs.items()
    ] + [F("the same C_x in every run", r["same_c_x_in_every_run"], target=("==", True))]


def _compile_backend(r: Result) -> list[dict]:
    return [
        F(
            "compile time, older over newer XLA:CPU code generator",
            r["compile_ratio_llvm_to_fusion"],
        ),
        F("steady fit time, older over newer", r["steady_fit_ratio_llvm_to_fusion"]),
        F("C_x relative difference", r["c_x_mean_relative_difference"]),
    ]


def _fit_file_io(r: Result) -> list[dict]:
    out = []
    for engine, e in r["engines"].items():
        s = e.get("without_pointwise")
        if not e.get("installed") or not s:
            continue
        out.append(
            F(
                f"{engine}: write a fleet set's fit file",
                s["write_seconds_median"],
                unit="s",
                note=f"read {s['read_seconds_median']:.3f} s, {s['file_mb']:.1f} MB",
            )
        )
    return out


def _online_curvature_cost(r: Result) -> list[dict]:
    return [
        F(
            f"{k}: Gauss-Newton pass on one step",
            v["gauss_newton"] / 1000.0,
            unit="ms",
            note=f"exact Hessian {r['hessian_over_gauss_newton'][k]:.2f}× that",
        )
        for k, v in r["fastest_us"].items()
    ]


def _online_speed_fleet(r: Result) -> list[dict]:
    """The 10⁴-car call of ``online_speed`` (its ``vmapped_fleet``): none where it did not run."""
    if "per_car_hour_s" not in r:
        if "failed" not in r:
            return []
        return [F(f"{r['n_cars']:,} cars in one call", None, note=r["failed"])]
    return [
        F(
            f"{r['n_cars']:,} cars in one call, per car-hour",
            r["per_car_hour_s"],
            unit="s",
            count=r["n_cars"],
            note=f"{r['compile_and_first_run_s']:.0f} s compiling and a first run",
        ),
        F("the 10⁴-car call's peak RSS", r["peak_rss_mb"], unit="MB"),
    ]


def _stream_stage_speed(r: Result) -> list[dict]:
    return [
        F(
            f"{k.replace('_', ' ')}: per-drive stage CPU s per hour",
            v["after"]["cpu_s"]["total"],
            unit="s",
            target=("<=", r["target_cpu_s_per_hour"]),
        )
        for k, v in r["runs"].items()
    ]


def _windows_step_speed(r: Result) -> list[dict]:
    return [
        F("force-density EM speed-up", r["speedup"], count=r["drives"]),
        F(
            "drives at least as likely as with the plain EM",
            r["drives_after_at_least_as_likely_as_before"],
            count=r["drives"],
        ),
    ]


def _streams_speed(r: Result) -> list[dict]:
    return [
        F(
            f"{x['hours']} h {x['format']}: read, validate, features",
            x["s_per_hour"],
            unit="s/h",
            target=("<=", r["target_s_per_hour"]),
            note=f"peak {x['peak_mb']:.0f} MB, CPU {x['cpu_s']:.1f} s",
        )
        for x in r["runs"]
    ]


def _can_speed(r: Result) -> list[dict]:
    return [
        F(
            "candump decode, wall s per hour of bus",
            r["candump_s_per_hour"],
            unit="s",
            target=("<=", r["target_s_per_hour_candump"]),
        ),
        F(
            "candump peak over baseline",
            r["candump_peak_over_baseline_mb"],
            unit="MB",
            target=("<=", r["target_peak_mb"]),
        ),
        F(
            "speed-up over per-frame decoding",
            r["speedup_vs_per_frame_wall"],
            target=(">=", r["target_speedup_vs_per_frame"]),
        ),
        F("BLF, s per hour", r["blf_s_per_hour"], unit="s"),
        F("ASC, s per hour", r["asc_s_per_hour"], unit="s"),
    ]


def _simulate_speed(r: Result) -> list[dict]:
    return [
        F(f"simulate {x['hours']:g} h, {x['tyre_model']} truth", x["median_wall_s"], unit="s")
        for x in r["rows"]
    ]


def _physics_speed(r: Result) -> list[dict]:
    return [
        F(
            f"{k}: throughput over a copy",
            v["ratio_to_copy"],
            note=f"{v['elements_per_s'] / 1e6:.0f} M slips/s",
        )
        for k, v in r["results"].items()
    ] + [
        F(
            "force and slope at ≥ half a copy's speed",
            r["meets_target_force_and_slope"],
            target=("==", True),
        ),
        F(
            "force and parameter gradient at ≥ half a copy's speed",
            r["meets_target_force_and_param_grad"],
            target=("==", True),
        ),
    ]


def _real_log_features(r: Result) -> list[dict]:
    return [F(k.replace("_", " "), bool(v), target=("==", True)) for k, v in r["checks"].items()]


def _real_vs_sim(r: Result) -> list[dict]:
    m = r["metrics"]
    out = r["outside_factor_1.33"]
    return [
        F(
            "metrics within a factor 1.33 of the real log",
            len(m) - len(out),
            count=len(m),
            note="outside: " + ", ".join(out),
        ),
    ]


EXTRACTORS: dict[str, Callable[[Result], list[dict]]] = {
    "external_drives": _external_drives,
    "tyre_recovery": _tyre_recovery,
    "identification": _identification,
    "online_agreement": _online_agreement,
    "online_change": _online_change,
    "online_speed": _online_speed,
    "online_outliers": _online_outliers,
    "discovery": _discovery,
    "discovery_more_null": _discovery_more_null,
    "discovery_tread": _discovery_tread,
    "fleet_vs_ols": _fleet_vs_ols,
    "fleet_nuts": _fleet_nuts,
    "fleet_run": _fleet_run,
    "tyre_speed": _tyre_speed,
    "fit_memory": _fit_memory,
    "wear_history": _wear_history,
    "wear_thesis": _wear_thesis,
    "wear_recovery": _wear_recovery,
    "vmax": _vmax,
    "real_log_fit": _real_log_fit,
    "shape_prior": _shape_prior,
    "block_offsets": _block_offsets,
    "stored_program": _stored_program,
    "compile_backend": _compile_backend,
    "fit_file_io": _fit_file_io,
    "online_curvature_cost": _online_curvature_cost,
    "stream_stage_speed": _stream_stage_speed,
    "windows_step_speed": _windows_step_speed,
    "streams_speed": _streams_speed,
    "can_speed": _can_speed,
    "simulate_speed": _simulate_speed,
    "physics_speed": _physics_speed,
    "real_log_features": _real_log_features,
    "real_vs_sim": _real_vs_sim,
}


def load(stem: str, folder: Path = RESULTS) -> Result:
    """The result file ``benchmarks/results/STEM.json``."""
    return json.loads((folder / f"{stem}.json").read_text())


def figures(stem: str, result: Result | None = None, folder: Path = RESULTS) -> list[dict]:
    """The figures of result file ``STEM.json``: its own, else read from its payload."""
    result = load(stem, folder) if result is None else result
    if result.get("figures"):
        return result["figures"]
    extract = EXTRACTORS.get(stem)
    if extract is not None:
        return extract(result)
    # A variant run of a benchmark (external_drives_load_sensitivity): its benchmark's figures,
    # none of them a headline.
    base = max((k for k in EXTRACTORS if stem.startswith(k + "_")), key=len, default=None)
    if base is None:
        return []
    try:
        figs = EXTRACTORS[base](result)
    except (KeyError, TypeError, ValueError):
        return []
    return [{**f, "headline": False} for f in figs]
