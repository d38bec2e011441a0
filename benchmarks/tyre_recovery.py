"""Recovery of C_x and μ_max from simulated drives: this posterior vs OLS vs total least squares.

For each setting (truth curve brush / Magic Formula, with / without ABS events, noise level)
simulate independent drives of a ``compact_fwd`` with known tyres (tyre type cycled over
winter / all-season / summer on dry asphalt), run the stream pipeline, and fit

* this package's errors-in-variables posterior (fast path: MAP + Laplace; NUTS for all reps is
  too slow on the 2-core machine — see ``tyre_speed.json``),
* ordinary least squares of force on measured slip over the same windows (the thesis' kind of
  fit, slope only — the thesis had no μ_max estimate from driving data),
* a total-least-squares (Deming) slope with the known noise ratio of the windows.

Truth C_x is the driven wheels' mean C_x (at their simulated temperature) over the drive; truth
μ_max that of the surface. Reported per setting: bias and RMSE (relative) of C_x for all three
and of μ_max for the posterior, and the coverage of its central 50 % and 90 % intervals.

Usage: ``python benchmarks/tyre_recovery.py [--quick] [--reps N] [--duration S]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from tyrebayes.inference.tyre_data import observations_from_features, stack_drives  # noqa: E402
from tyrebayes.inference.tyre_fit import fit_tyre  # noqa: E402
from tyrebayes.physics.vehicle import load_vehicle  # noqa: E402
from tyrebayes.simulate.drive import simulate_drive  # noqa: E402
from tyrebayes.simulate.profiles import ProfileOptions  # noqa: E402
from tyrebayes.simulate.sensors import SensorModel, scale_noise  # noqa: E402
from tyrebayes.streams import compute_features, validate_stream  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "tyre_recovery.json"
TYRES = ("winter", "all_season", "summer")


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


def one_drive(seed: int, setting: dict, duration_s: float, vehicle, pad_to: int) -> dict:
    tyre = TYRES[seed % len(TYRES)]
    profile = ProfileOptions(n_abs_events=setting["abs_events"])
    sensor = scale_noise(SensorModel(), setting["noise"])
    df, truth = simulate_drive(
        seed,
        vehicle,
        tyre,
        duration_s=duration_s,
        profile=profile,
        tyre_model=setting["truth"],
        sensor=sensor,
        ambient_c=15.0,
    )
    features = compute_features(validate_stream(df, vehicle), vehicle)
    ambient = float(np.nanmean(df["ambient_temperature"])) if "ambient_temperature" in df else 20.0
    windows = observations_from_features(features, temperature_c=ambient)
    obs = stack_drives([windows], ["dry"], pad_to=pad_to)
    fit = fit_tyre(obs, method="fast", seed=seed)
    c_x_draws, mu_draws = fit.draws("c_x"), fit.draws("mu_max")[:, 0]
    slip_w = ~windows["at_limit"]
    x, y = windows["slip"][slip_w], windows["rho"][slip_w]
    c_x_true = float(np.mean(truth.c_x))

    def covers(draws, true, p):
        lo, hi = np.quantile(draws, [0.5 - p / 2, 0.5 + p / 2])
        return bool(lo <= true <= hi)

    return {
        "seed": seed,
        "tyre": tyre,
        "c_x_true": c_x_true,
        "mu_true": float(truth.mu_max),
        "c_x_post": float(np.mean(c_x_draws)),
        "mu_post": float(np.mean(mu_draws)),
        "c_x_ols": ols_slope(x, y),
        "c_x_tls": tls_slope(x, y, windows["slip_sd"][slip_w], windows["rho_sd"][slip_w]),
        "c_x_cover50": covers(c_x_draws, c_x_true, 0.5),
        "c_x_cover90": covers(c_x_draws, c_x_true, 0.9),
        "mu_cover50": covers(mu_draws, truth.mu_max, 0.5),
        "mu_cover90": covers(mu_draws, truth.mu_max, 0.9),
        "mu_observed": bool(fit.mu_observed["dry"]),
        "converged": bool(fit.diagnostics.converged),
        "n_windows": obs.n_used,
        "n_abs_windows": obs.n_limit,
    }


def summarise(rows: list[dict]) -> dict:
    def rel(est, true):
        e = np.array([r[est] for r in rows]) / np.array([r[true] for r in rows]) - 1.0
        return {"bias": float(np.mean(e)), "rmse": float(np.sqrt(np.mean(e**2)))}

    out = {
        "n": len(rows),
        "c_x_posterior": rel("c_x_post", "c_x_true"),
        "c_x_ols": rel("c_x_ols", "c_x_true"),
        "c_x_tls": rel("c_x_tls", "c_x_true"),
        "mu_posterior": rel("mu_post", "mu_true"),
        "c_x_coverage_50": float(np.mean([r["c_x_cover50"] for r in rows])),
        "c_x_coverage_90": float(np.mean([r["c_x_cover90"] for r in rows])),
        "mu_coverage_50": float(np.mean([r["mu_cover50"] for r in rows])),
        "mu_coverage_90": float(np.mean([r["mu_cover90"] for r in rows])),
        "mu_observed_share": float(np.mean([r["mu_observed"] for r in rows])),
        "converged_share": float(np.mean([r["converged"] for r in rows])),
    }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 reps of 5-minute drives")
    parser.add_argument("--reps", type=int, default=12, help="drives per setting")
    parser.add_argument("--duration", type=float, default=600.0, help="drive length [s]")
    parser.add_argument("--out", default=str(RESULTS))
    args = parser.parse_args()
    reps, duration = (2, 300.0) if args.quick else (args.reps, args.duration)
    settings = [
        {"name": "brush_abs", "truth": "brush", "abs_events": 2, "noise": 1.0},
        {"name": "brush_no_abs", "truth": "brush", "abs_events": 0, "noise": 1.0},
        {"name": "magic_formula_abs", "truth": "magic_formula", "abs_events": 2, "noise": 1.0},
        {"name": "brush_abs_noise_x2", "truth": "brush", "abs_events": 2, "noise": 2.0},
    ]
    if args.quick:
        settings = settings[:2]
    vehicle = load_vehicle("compact_fwd")
    # One padded size for every drive: the fast path compiles once.
    pad_to = 1 << int(np.ceil(np.log2(duration * 4 + 64)))
    t0 = time.perf_counter()
    results = {}
    for setting in settings:
        rows = [one_drive(1000 + i, setting, duration, vehicle, pad_to) for i in range(reps)]
        results[setting["name"]] = {"setting": setting, "summary": summarise(rows), "drives": rows}
        s = results[setting["name"]]["summary"]
        print(
            f"{setting['name']:22s} n={s['n']:3d}  C_x bias post "
            f"{100 * s['c_x_posterior']['bias']:+5.1f}% "
            f"OLS {100 * s['c_x_ols']['bias']:+5.1f}% TLS {100 * s['c_x_tls']['bias']:+5.1f}%  "
            f"RMSE post {100 * s['c_x_posterior']['rmse']:4.1f}%  cov50/90 "
            f"{s['c_x_coverage_50']:.2f}/{s['c_x_coverage_90']:.2f}  mu bias "
            f"{100 * s['mu_posterior']['bias']:+5.1f}% cov90 {s['mu_coverage_90']:.2f} "
            f"observed {s['mu_observed_share']:.2f}",
            flush=True,
        )
    payload = {
        "description": __doc__.splitlines()[0],
        "method": "fast path (MAP + Laplace) for every rep",
        "vehicle": "compact_fwd",
        "drive_duration_s": duration,
        "reps_per_setting": reps,
        "wall_time_s": time.perf_counter() - t0,
        "targets": {
            "c_x_abs_bias_max": 0.02,
            "coverage_tolerance": 0.05,
            "mu_abs_bias_max_with_abs": 0.05,
        },
        "results": results,
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(payload, indent=2) + "\n")
    os.replace(tmp, out)
    print(f"wrote {out} in {payload['wall_time_s']:.0f} s")


if __name__ == "__main__":
    main()
