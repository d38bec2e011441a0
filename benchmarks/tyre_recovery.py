"""Recovery of C_x and μ_max from simulated drives: this posterior vs OLS vs total least squares.

For each setting (truth curve Magic Formula with its shape drawn from the shipped database of
measured tyres, or the brush; with / without ABS events; noise level) simulate independent drives
of a ``compact_fwd`` with known tyres (tyre type cycled over winter / all-season / summer on dry
asphalt), run the stream pipeline, and fit

The car driven in each drive is drawn around the vehicle file (``VehicleSpread``: static load
share, CoG height, pitch gradient) and its IMU gain with the sensor offsets, while the pipeline
and the fit assume the file, as they would on a real car: the coverage check then tests the
intervals in the world their priors describe. ``force_gain_true`` is the measured-over-true ρ_x
this gives (``force_gain``), ``force_gain_post`` the posterior mean of the model's force gain.
Likewise its tyres heat with thermal coefficients drawn around the nominal ones
(``ThermalSpread``), while the pipeline estimates their temperature along the drive with the
nominal model (``features_tyre_temperature``); the rows record the mean estimated and true
temperature rise and how much the true C_x varied along the drive (``c_x_true_time_sd``).

* this package's errors-in-variables posterior (fast path: MAP + Laplace; NUTS for all reps is
  too slow on the 2-core machine — see ``tyre_speed.json``) with its default mean model
  (``"magic"``: the Magic Formula curve with its shape drawn from the measured tyres' spread),
* the same posterior with the plain brush curve (``model="brush"``, the thesis' model; columns
  ``*_brush``), to measure what the curve family does,
* ordinary least squares of force on measured slip over the same windows (the thesis' kind of
  fit, slope only — the thesis had no μ_max estimate from driving data),
* a total-least-squares (Deming) slope with the known noise ratio of the windows.

Truth C_x is the driven wheels' mean C_x (at their simulated temperature) over the drive; truth
μ_max that of the surface. Reported per setting: bias and RMSE (relative) of C_x for all three
and of μ_max for the posterior, and the coverage of its central 50 % and 90 % intervals.

* Fits that did not converge (``diagnostics.converged`` False) are excluded from every bias,
  RMSE and coverage number and counted separately (``n_not_converged``); OLS and TLS are
  summarised over the same drives so the columns compare like with like.
* μ_max bias/RMSE/coverage are computed only over converged drives with at least one detected
  ABS window; without ABS the μ_max posterior is the prior by construction, so only the share of
  drives flagged ``mu_observed`` is reported (it should be ~0).
* Simulated streams that the stream validator rejects (with noise ×2 the accelerometer's
  vibration noise can push ``az`` past its ±40 m/s² range) are not fits: they are listed in
  ``rejected_streams`` and replaced by the next seed.
* With Magic Formula truth neither model curve has the right shape after the peak: μ_max
  coverage there also tests the shared ABS force ratio's prior.

The diagnostic settings ``<setting>_no_load`` (run only when named) repeat each Magic Formula
setting drive for drive with the curves' load dependences set to zero: what the model's single
C_x at every load costs against real tyres' load-dependent stiffness (``--merge`` of both runs
reports the pooled coverage with and without, ``load_dependence_diagnosis``). The settings
``<setting>_load_sensitive`` fit the same drives as each setting with the load sensitivity of
the slip stiffness (``TyrePriors().with_load_sensitivity()``); the rows then record the
posterior of q against the drawn tyre's PKX2/PKX1 + PKX3 (``load_sensitivity`` in the summary).

Drives last one hour by default, as the issue asks (``--duration`` for shorter ones), 100 per
setting (the issue asks for at least 50; at 50 one binomial sd of a coverage share is 7 points at
50 %, more than the ±5-point target, at 100 it is 5). Two settings of 100 one-hour drives (both
models fitted on each) took 986 and 1,019 s in two processes side by side on the 2-core machine;
``--settings`` runs a subset so that settings can run in separate processes, and ``--merge``
combines their files.

Usage: ``python benchmarks/tyre_recovery.py [--quick] [--reps N] [--duration S] [--settings A,B]
[--out FILE]``; ``--merge A.json B.json [--out FILE]`` combines runs of different settings.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import jax
from _results import RESERVED, write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from tyrebayes import (  # noqa: E402
    BadInputError,
    TyrePriors,
    compute_features,
    features_tyre_temperature,
    fit_tyre,
    load_vehicle,
    observations_from_features,
    stack_drives,
    validate_stream,
)
from tyrebayes.simulate import (  # noqa: E402
    ProfileOptions,
    SensorModel,
    ThermalSpread,
    TyreSpec,
    VehicleSpread,
    draw_true_thermal,
    draw_true_vehicle,
    drawn_curve,
    force_gain,
    scale_noise,
    simulate_drive,
)

RESULTS = Path(__file__).parent / "results" / "tyre_recovery.json"
TYRES = ("winter", "all_season", "summer")
# Magic Formula truths draw each drive's curve shape from the shipped database of measured
# tyres (simulate_drive with a tyre type); the brush truth is a curve outside the model's family
# (it bends from the first newton, no measured tyre does), kept to show what the fit does then.
_MAIN_SETTINGS = (
    {"name": "magic_formula_abs", "truth": "magic_formula", "abs_events": 2, "noise": 1.0},
    {"name": "magic_formula_no_abs", "truth": "magic_formula", "abs_events": 0, "noise": 1.0},
    {"name": "magic_formula_abs_noise_x2", "truth": "magic_formula", "abs_events": 2, "noise": 2.0},
    {"name": "brush_abs", "truth": "brush", "abs_events": 2, "noise": 1.0},
)
# Diagnoses, not defaults: the same drives as the Magic Formula settings (same seeds, the same
# curve shapes) with the curves' load dependences (PKX2-3, PDX2, PEX2-3) set to zero, as the
# independent generator's tyres have none. The model has one C_x at every load.
# And the same drives as every setting fitted with the load sensitivity of the slip stiffness
# (TyrePriors().with_load_sensitivity(): q with the measured tyres' prior).
SETTINGS = (
    _MAIN_SETTINGS
    + tuple(
        {**st, "name": f"{st['name']}_no_load", "load_dependence": False, "diagnostic": True}
        for st in _MAIN_SETTINGS
        if st["truth"] == "magic_formula"
    )
    + tuple(
        {**st, "name": f"{st['name']}_load_sensitive", "load_sensitive": True, "diagnostic": True}
        for st in _MAIN_SETTINGS
    )
)


def ols_slope(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.polyfit(x, y, 1)[0])


def tls_slope(x: np.ndarray, y: np.ndarray, x_sd: np.ndarray, y_sd: np.ndarray) -> float:
    """Deming regression with the noise-variance ratio δ = var(y noise) / var(x noise)."""
    delta = float(np.mean(y_sd**2) / np.mean(x_sd**2))
    sxx, syy = np.var(x), np.var(y)
    sxy = np.mean((x - x.mean()) * (y - y.mean()))
    return float(
        (syy - delta * sxx + np.sqrt((syy - delta * sxx) ** 2 + 4 * delta * sxy**2)) / (2 * sxy)
    )


def _load_sensitivity_true(seed: int, setting: dict) -> float | None:
    """PKX2/PKX1 + PKX3 of the curve the drive's tyres have (0 without load dependence)."""
    if setting["truth"] != "magic_formula":
        return None
    if not setting.get("load_dependence", True):
        return 0.0
    curve = drawn_curve(seed)
    return float(curve.pkx2 / curve.pkx1 + curve.pkx3)


def _without_load_dependence(seed: int, tyre_type: str) -> TyreSpec:
    """The tyre ``simulate_drive(seed, ..., tyre_type)`` draws, its load dependences set to 0."""
    import equinox as eqx

    curve = drawn_curve(seed)
    flat = eqx.tree_at(
        lambda c: (c.pkx2, c.pkx3, c.pdx2, c.pex2, c.pex3), curve, (0.0, 0.0, 0.0, 0.0, 0.0)
    )
    return TyreSpec.from_type(tyre_type, magic_formula=flat)


def simulated_observations(seed: int, setting: dict, duration_s: float, vehicle, pad_to: int):
    """One simulated drive of a setting through the stream pipeline.

    Returns ``(obs, windows, truth, extras)``: the padded observations, the drive's windows, the
    simulator's truth and a dict of what the rows record besides the fit (tyre type, drawn car,
    ambient and the estimated tyre temperature).
    """
    tyre_type = TYRES[seed % len(TYRES)]
    tyre = tyre_type
    if not setting.get("load_dependence", True):
        tyre = _without_load_dependence(seed, tyre_type)
    profile = ProfileOptions(n_abs_events=setting["abs_events"])
    sensor = scale_noise(SensorModel(), setting["noise"])
    # The car driven is not the vehicle file (load share, CoG height, pitch gradient; the IMU's
    # gain is drawn with the sensor offsets): the fit's force-gain prior describes this spread.
    car = draw_true_vehicle(np.random.default_rng([seed, 7]), vehicle, VehicleSpread())
    # Nor do its tyres heat exactly as the pipeline's nominal thermal model assumes.
    thermal = draw_true_thermal(np.random.default_rng([seed, 8]), ThermalSpread())
    df, truth = simulate_drive(
        seed,
        car,
        tyre,
        duration_s=duration_s,
        profile=profile,
        tyre_model=setting["truth"],
        sensor=sensor,
        ambient_c=15.0,
        thermal=thermal,
    )
    features = compute_features(validate_stream(df, vehicle), vehicle)
    ambient = float(np.nanmean(df["ambient_temperature"])) if "ambient_temperature" in df else 20.0
    tyre_temperature = features_tyre_temperature(features, ambient_c=ambient)
    windows = observations_from_features(features, temperature_c=tyre_temperature)
    obs = stack_drives([windows], ["dry"], pad_to=pad_to)
    extras = {
        "tyre": tyre_type,
        "car": car,
        "ambient": ambient,
        "tyre_temperature": tyre_temperature,
    }
    return obs, windows, truth, extras


def one_drive(seed: int, setting: dict, duration_s: float, vehicle, pad_to: int) -> dict:
    obs, windows, truth, extras = simulated_observations(seed, setting, duration_s, vehicle, pad_to)
    tyre, car, ambient = extras["tyre"], extras["car"], extras["ambient"]
    tyre_temperature = extras["tyre_temperature"]
    priors = TyrePriors().with_load_sensitivity() if setting.get("load_sensitive") else None
    fit = fit_tyre(obs, priors=priors, method="fast", seed=seed)
    brush = fit_tyre(obs, priors=priors, method="fast", seed=seed, model="brush")
    c_x_draws, mu_draws = fit.draws("c_x"), fit.draws("mu_max")[:, 0]
    c_x_brush, mu_brush = brush.draws("c_x"), brush.draws("mu_max")[:, 0]
    slip_windows = windows.select(~windows.at_limit)
    x, y = slip_windows.slip, slip_windows.rho
    c_x_true = float(np.mean(truth.c_x))
    load_draws = np.asarray(fit.draws("load_sensitivity")) if priors is not None else None

    def covers(draws, true, p):
        lo, hi = np.quantile(draws, [0.5 - p / 2, 0.5 + p / 2])
        return bool(lo <= true <= hi)

    return {
        "seed": seed,
        "tyre": tyre,
        "c_x_true": c_x_true,
        "c_x_true_time_sd": float(np.std(truth.c_x) / c_x_true),
        "tyre_temperature_rise_est": float(np.mean(tyre_temperature) - ambient),
        "tyre_temperature_rise_true": float(np.mean(truth.tyre_temperature_c) - ambient),
        "mu_true": float(truth.mu_max),
        "force_gain_true": force_gain(car, vehicle, truth.ax_gain),
        "force_gain_post": float(np.mean(fit.draws("force_gain"))),
        "c_x_post": float(np.mean(c_x_draws)),
        "mu_post": float(np.mean(mu_draws)),
        "c_x_ols": ols_slope(x, y),
        "c_x_tls": tls_slope(x, y, slip_windows.slip_sd, slip_windows.rho_sd),
        "c_x_cover50": covers(c_x_draws, c_x_true, 0.5),
        "c_x_cover90": covers(c_x_draws, c_x_true, 0.9),
        "mu_cover50": covers(mu_draws, truth.mu_max, 0.5),
        "mu_cover90": covers(mu_draws, truth.mu_max, 0.9),
        "c_x_sd": float(np.std(c_x_draws)),
        "mu_sd": float(np.std(mu_draws)),
        "mu_observed": bool(fit.mu_observed["dry"]),
        # q = d ln C_x / d(ΔF_z/F_z) at the static load, where the simulator's curve has its
        # nominal load (None for the brush truth, which has no load dependence).
        "load_sensitivity_true": _load_sensitivity_true(seed, setting),
        "load_sensitivity_post": None if load_draws is None else float(np.mean(load_draws)),
        "load_sensitivity_sd": None if load_draws is None else float(np.std(load_draws)),
        "curve_shape": float(np.mean(fit.draws("curve_shape_c"))),
        "curve_curvature": float(np.mean(fit.draws("curve_curvature_e"))),
        "adequate": bool(fit.adequacy.adequate),
        "c_x_brush": float(np.mean(c_x_brush)),
        "mu_brush": float(np.mean(mu_brush)),
        "c_x_brush_cover50": covers(c_x_brush, c_x_true, 0.5),
        "c_x_brush_cover90": covers(c_x_brush, c_x_true, 0.9),
        "mu_brush_cover50": covers(mu_brush, truth.mu_max, 0.5),
        "mu_brush_cover90": covers(mu_brush, truth.mu_max, 0.9),
        "brush_converged": bool(brush.diagnostics.converged),
        "converged": bool(fit.diagnostics.converged),
        "reason": fit.diagnostics.reason,
        "n_windows": obs.n_used,
        "n_abs_windows": obs.n_limit,
    }


def _rel(rows: list[dict], est: str, true: str) -> dict:
    if not rows:
        return {"bias": None, "rmse": None, "bias_se": None}
    e = np.array([r[est] for r in rows]) / np.array([r[true] for r in rows]) - 1.0
    return {
        "bias": float(np.mean(e)),
        "rmse": float(np.sqrt(np.mean(e**2))),
        # Monte Carlo standard error of the bias (sd / sqrt(n)).
        "bias_se": float(np.std(e, ddof=1) / np.sqrt(len(e))) if len(e) > 1 else None,
    }


def _share(rows: list[dict], key: str) -> float | None:
    return float(np.mean([r[key] for r in rows])) if rows else None


def _load_sensitivity_summary(rows: list[dict]) -> dict | None:
    """The posterior of q against the drawn tyres' (Magic Formula truths only)."""
    rows = [
        r
        for r in rows
        if r.get("load_sensitivity_true") is not None and r.get("load_sensitivity_post") is not None
    ]
    if not rows:
        return None
    true = np.array([r["load_sensitivity_true"] for r in rows])
    post = np.array([r["load_sensitivity_post"] for r in rows])
    sd = np.array([r["load_sensitivity_sd"] for r in rows])
    return {
        "n": len(rows),
        "true_mean": float(true.mean()),
        "post_mean": float(post.mean()),
        "rmse": float(np.sqrt(np.mean((post - true) ** 2))),
        "post_sd_mean": float(sd.mean()),
        # Normal 90 % interval of the Laplace posterior.
        "coverage_90": float(np.mean(np.abs(post - true) <= 1.645 * sd)),
    }


def summarise(rows: list[dict]) -> dict:
    """Per-setting summary over converged fits only (not-converged fits are counted apart)."""
    ok = [r for r in rows if r["converged"]]
    with_abs = [r for r in ok if r["n_abs_windows"] > 0]
    ok_brush = [r for r in rows if r["brush_converged"]]
    brush_abs = [r for r in ok_brush if r["n_abs_windows"] > 0]
    return {
        "n": len(rows),
        "n_converged": len(ok),
        "n_not_converged": len(rows) - len(ok),
        "converged_share": float(len(ok) / len(rows)) if rows else None,
        "not_converged_reasons": sorted({r["reason"] for r in rows if not r["converged"]}),
        "c_x_posterior": _rel(ok, "c_x_post", "c_x_true"),
        "c_x_ols": _rel(ok, "c_x_ols", "c_x_true"),
        "c_x_tls": _rel(ok, "c_x_tls", "c_x_true"),
        "c_x_coverage_50": _share(ok, "c_x_cover50"),
        "c_x_coverage_90": _share(ok, "c_x_cover90"),
        # Binomial sd of a coverage share at its nominal value: how far chance alone moves it.
        "coverage_binomial_sd_50_90": [
            float(np.sqrt(p * (1 - p) / max(len(ok), 1))) for p in (0.5, 0.9)
        ],
        "c_x_rel_sd_mean": (
            float(np.mean([r["c_x_sd"] / r["c_x_post"] for r in ok])) if ok else None
        ),
        # μ_max only where the drive had detected ABS windows (else it is the prior).
        "n_with_abs_windows": len(with_abs),
        "mu_posterior": _rel(with_abs, "mu_post", "mu_true"),
        "mu_coverage_50": _share(with_abs, "mu_cover50"),
        "mu_coverage_90": _share(with_abs, "mu_cover90"),
        "mu_observed_share_with_abs": _share(with_abs, "mu_observed"),
        # Over all converged drives: for a no-ABS setting this should be ~0.
        "mu_observed_share": _share(ok, "mu_observed"),
        "curve_shape_mean": float(np.mean([r["curve_shape"] for r in ok])) if ok else None,
        "load_sensitivity": _load_sensitivity_summary(ok),
        "brush": {
            "n_converged": len(ok_brush),
            "c_x_posterior": _rel(ok_brush, "c_x_brush", "c_x_true"),
            "c_x_coverage_50": _share(ok_brush, "c_x_brush_cover50"),
            "c_x_coverage_90": _share(ok_brush, "c_x_brush_cover90"),
            "mu_posterior": _rel(brush_abs, "mu_brush", "mu_true"),
            "mu_coverage_50": _share(brush_abs, "mu_brush_cover50"),
            "mu_coverage_90": _share(brush_abs, "mu_brush_cover90"),
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 reps of 5-minute drives")
    parser.add_argument("--reps", type=int, default=100, help="drives per setting")
    parser.add_argument("--duration", type=float, default=3600.0, help="drive length [s]")
    parser.add_argument("--out", default=str(RESULTS))
    parser.add_argument(
        "--settings",
        default="",
        help="comma-separated setting names to run (default: all but the diagnostic ones)",
    )
    parser.add_argument(
        "--merge", nargs="+", default=None, help="merge results files of separate runs into --out"
    )
    args = parser.parse_args()
    if args.merge:
        merge(args.merge, Path(args.out))
        return
    reps, duration = (2, 300.0) if args.quick else (args.reps, args.duration)
    # Diagnostic settings run when named only.
    settings = [st for st in SETTINGS if not st.get("diagnostic")]
    if args.quick:
        settings = settings[:2]
    if args.settings:
        wanted = args.settings.split(",")
        unknown = sorted(set(wanted) - {st["name"] for st in SETTINGS})
        if unknown:
            parser.error(
                f"--settings: expected names from {[st['name'] for st in SETTINGS]}, got {unknown}"
            )
        settings = [st for st in SETTINGS if st["name"] in wanted]
    vehicle = load_vehicle("compact_fwd")
    # One padded size for every drive: the fast path compiles once.
    pad_to = 1 << int(np.ceil(np.log2(duration * 4 + 64)))
    duration_note = (
        "one-hour drives as the issue asks"
        if duration >= 3600
        else f"{duration / 60:.0f}-minute drives instead of the issue's one-hour drives "
        "(one-hour drives x 200 do not fit the benchmark's wall-time budget on 2 shared cores)"
    )
    print(f"{reps} drives per setting, {duration_note}", flush=True)
    out = Path(args.out)
    t0 = time.perf_counter()
    results = {}
    for setting in settings:
        rows, rejected = [], []
        seed = 1000
        # A simulated stream the validator rejects (e.g. doubled vibration noise pushing az past
        # its physical range) is not a fit failure: it is recorded and the next seed is drawn.
        while len(rows) < reps and seed < 1000 + 2 * reps:
            try:
                rows.append(one_drive(seed, setting, duration, vehicle, pad_to))
            except BadInputError as err:
                rejected.append({"seed": seed, "reason": str(err).splitlines()[0]})
            seed += 1
            if len(rows) % 10 == 0 and rows and rows[-1]["seed"] == seed - 1:
                print(f"  {setting['name']}: {len(rows)}/{reps}", flush=True)
        print(
            f"  {setting['name']}: {len(rows)} drives, {len(rejected)} streams rejected by "
            f"validation ({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )
        summary = summarise(rows)
        summary["n_streams_rejected_by_validation"] = len(rejected)
        results[setting["name"]] = {
            "setting": setting,
            "summary": summary,
            "rejected_streams": rejected,
            "drives": rows,
        }
        print(format_summary(setting["name"], results[setting["name"]]["summary"]), flush=True)
        write(out, payload(results, duration, duration_note, reps, time.perf_counter() - t0))
    final = payload(results, duration, duration_note, reps, time.perf_counter() - t0)
    write(out, final)
    print(f"({duration_note}) wrote {out} in {final['wall_time_s']:.0f} s")


def _pct(x: float | None, fmt: str = "+5.1f") -> str:
    return "  n/a" if x is None else format(100 * x, fmt) + "%"


def format_summary(name: str, s: dict) -> str:
    line = (
        f"{name:20s} conv {s['n_converged']}/{s['n']}"
        f"  C_x bias post {_pct(s['c_x_posterior']['bias'])}"
        f" OLS {_pct(s['c_x_ols']['bias'])} TLS {_pct(s['c_x_tls']['bias'])}"
        f"  RMSE post {_pct(s['c_x_posterior']['rmse'], '4.1f')}"
        f"  cov50/90 {s['c_x_coverage_50']:.2f}/{s['c_x_coverage_90']:.2f}"
    )
    if s["n_with_abs_windows"]:
        line += (
            f"  | mu (n={s['n_with_abs_windows']} w/ ABS) bias {_pct(s['mu_posterior']['bias'])}"
            f" RMSE {_pct(s['mu_posterior']['rmse'], '4.1f')}"
            f" cov50/90 {s['mu_coverage_50']:.2f}/{s['mu_coverage_90']:.2f}"
        )
    line += f"  mu_observed share {s['mu_observed_share']:.2f}  shape {s['curve_shape_mean']:.2f}"
    b = s["brush"]
    line += (
        f"\n{'':20s} brush model: C_x bias {_pct(b['c_x_posterior']['bias'])}"
        f" RMSE {_pct(b['c_x_posterior']['rmse'], '4.1f')}"
        f" cov50/90 {b['c_x_coverage_50']:.2f}/{b['c_x_coverage_90']:.2f}"
    )
    if b["mu_posterior"]["bias"] is not None:
        line += (
            f"  mu bias {_pct(b['mu_posterior']['bias'])}"
            f" cov50/90 {b['mu_coverage_50']:.2f}/{b['mu_coverage_90']:.2f}"
        )
    return line


def payload(results: dict, duration: float, note: str, reps: int, wall: float) -> dict:
    return {
        "description": __doc__.splitlines()[0],
        "method": "fast path (MAP + Laplace) for every rep; default (Magic Formula) and brush "
        "models",
        "vehicle": "compact_fwd",
        "drive_duration_s": duration,
        "duration_note": note,
        "reps_per_setting": reps,
        "exclusions": "bias/RMSE/coverage over converged fits only; mu_max stats only over "
        "converged drives with >= 1 detected ABS window",
        "wall_time_s": wall,
        "targets": {
            "c_x_abs_bias_max": 0.02,
            "coverage_tolerance": 0.05,
            "mu_abs_bias_max_with_abs": 0.05,
        },
        "results": results,
        "pooled_c_x_coverage": pooled_coverage(results),
        **load_dependence_diagnosis(results),
        **load_sensitivity_comparison(results),
    }


def load_dependence_diagnosis(results: dict) -> dict:
    """Pooled C_x coverage of the no-load diagnostic settings beside the settings they repeat.

    Empty unless both a diagnostic setting and its counterpart are in ``results``.
    """
    pairs = [
        (name.removesuffix("_no_load"), name)
        for name in results
        if name.endswith("_no_load") and name.removesuffix("_no_load") in results
    ]
    if not pairs:
        return {}

    return {
        "load_dependence_diagnosis": {
            "settings": [base for base, _ in pairs],
            "with_load_dependence": _coverage(results, [base for base, _ in pairs]),
            "without_load_dependence": _coverage(results, [diag for _, diag in pairs]),
        }
    }


def load_sensitivity_comparison(results: dict) -> dict:
    """Pooled C_x coverage of the Magic Formula settings fitted with the load sensitivity, and
    without it where those settings are in ``results`` too (a ``--merge`` of both runs)."""
    fitted = [
        n
        for n, r in results.items()
        if r["setting"].get("load_sensitive") and r["setting"]["truth"] == "magic_formula"
    ]
    if not fitted:
        return {}
    comparison = {"settings": fitted, "with_load_sensitivity": _coverage(results, fitted)}
    plain = [n.removesuffix("_load_sensitive") for n in fitted]
    if all(n in results for n in plain):
        comparison["without_load_sensitivity"] = _coverage(results, plain)
    return {"load_sensitivity_comparison": comparison}


def pooled_coverage(results: dict) -> dict:
    """C_x coverage over the converged drives of every setting but the diagnostic ones."""
    return _coverage(results, [n for n, r in results.items() if not r["setting"].get("diagnostic")])


def _coverage(results: dict, names: list[str]) -> dict:
    """C_x coverage over the converged drives of the settings ``names``, together."""
    rows = [r for n in names for r in results[n]["drives"] if r["converged"]]
    return {
        "n": len(rows),
        "coverage_50": _share(rows, "c_x_cover50"),
        "coverage_90": _share(rows, "c_x_cover90"),
    }


def merge(paths: list[str], out: Path) -> None:
    """One results file from runs of different settings in separate processes (``--settings``)."""
    runs = [json.loads(Path(p).read_text()) for p in paths]
    first = runs[0]
    if any(r["drive_duration_s"] != first["drive_duration_s"] for r in runs):
        raise SystemExit("--merge: expected runs of one drive duration, got several")
    results = {name: res for r in runs for name, res in r["results"].items()}
    wall = sum(r["wall_time_s"] for r in runs)
    data = payload(
        results, first["drive_duration_s"], first["duration_note"], first["reps_per_setting"], wall
    )
    data["run_note"] = (
        "separate runs, in processes of their own ("
        + "; ".join(f"{','.join(r['results'])}: {r['wall_time_s']:.0f} s" for r in runs)
        + "); wall_time_s is their sum"
    )
    # This file's own run block is the merge's; each part keeps the revision that ran it.
    data["merged_from"] = [
        {
            "settings": list(r["results"]),
            "revision": r.get("run", {}).get("revision"),
            "date": r.get("run", {}).get("date"),
            "wall_time_s": r["wall_time_s"],
        }
        for r in runs
    ]
    write(out, data)
    print(f"merged {len(runs)} runs into {out}")


def _finite(x):
    """Non-finite floats (draws of a failed fit) as null: the file stays strict JSON."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_finite(v) for v in x]
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def write(out: Path, data: dict) -> None:
    data = {k: v for k, v in data.items() if k not in RESERVED}
    write_result("tyre_recovery", _finite(data), path=out)


if __name__ == "__main__":
    main()
