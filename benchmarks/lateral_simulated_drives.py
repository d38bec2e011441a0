"""The lateral fit on the package's own longitudinal drive simulator: what it reads, and the flag.

:func:`tyrebayes.simulate.simulate_drive` turns its car through planned corners and lane changes
(yaw rate a_y / V along the planned path, v_y from the rear axle's brush curve and the body's
lateral acceleration V r + v̇_y, the same c_y on both axles: a neutral car, whose understeer
gradient is zero). It differs from the lateral model in kind: a brush curve where the model fits
a Magic Formula, axle loads moved by braking and accelerating where the model takes static ones,
and a path the driver follows rather than a steering input; on it the understeer gradient is
all that steady cornering shows, and the axles' common stiffness rests on the yaw transients.
This benchmark fits each drive as ``fit-tyre`` does
(``validate_stream`` → ``cornering_observations`` → ``fit_lateral``, Laplace) and reports, per
drive: c_y front and rear against the simulated tyre's, whether the 90 % interval covers it, the
yaw-inertia factor the fit settled on and its distance from the vehicle file's in prior sds, and
whether the fit flagged itself not adequate (:mod:`tyrebayes.inference.lateral.posterior_checks`).

Figures: the fits flagged, the coverage of the truth among the fits that were not flagged (a fit
that is wrong should be flagged, so this is what a user would be told to trust), and the median
c_y over the truth (no target: it states the gap).

The cause, isolated on the cornering simulator (single-track dynamics integrated from a steering
input, the model's own assumptions): its ``steady`` manoeuvre (long constant-radius corners, the
transients weak) and its ``mixed`` one (transients strong), each with and without sensor noise,
over the same seeds, and the steady manoeuvre without noise but for one channel's (the
simulator's own white noise, :data:`CHANNEL_SD`). Reported per case: the median c_y over the
truth and the 90 % coverage of both axles.

Usage: ``python benchmarks/lateral_simulated_drives.py [--seeds 8] [--duration 600]``.
"""

from __future__ import annotations

import argparse
import math
import time

import jax
from _results import figure, write_result

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from tyrebayes import cornering_observations, fit_lateral, load_vehicle, validate_stream  # noqa: E402
from tyrebayes.inference.lateral import LateralPriors, NoCornering  # noqa: E402
from tyrebayes.inference.online import lateral_blocks, online_lateral  # noqa: E402
from tyrebayes.simulate import simulate_cornering, simulate_drive  # noqa: E402

VEHICLE = "compact_fwd"
TYRE = "summer"
RATE_HZ = 100.0


def _drive(seed: int, duration_s: float) -> dict:
    vehicle = load_vehicle(VEHICLE)
    frame, truth = simulate_drive(
        seed, vehicle, TYRE, duration_s=duration_s, sample_rate_hz=RATE_HZ
    )
    row: dict = {"seed": seed, "c_y_true": float(truth.c_y_per_rad)}
    try:
        obs = cornering_observations(validate_stream(frame, vehicle).data, vehicle)
    except NoCornering as err:
        return row | {"status": "no cornering", "reason": str(err).splitlines()[0]}
    start = time.perf_counter()
    fit = fit_lateral(obs)
    d = fit.to_dict()
    factor = float(np.exp(np.mean(np.log(fit.draws("yaw_inertia_factor")))))
    row |= {
        "status": "fitted",
        "fit_s": time.perf_counter() - start,
        "converged": bool(fit.converged),
        "identified": bool(fit.identified),
        "adequate": bool(fit.adequate),
        "adequacy_reasons": list(fit.fit.diagnostics.adequacy_reasons),
        "cornering_s": float(obs.cornering_seconds),
        "yaw_inertia_factor": factor,
        "yaw_inertia_prior_sds": math.log(factor) / LateralPriors().yaw_inertia_log_sd,
        "understeer_gradient": d["understeer_gradient"],
    }
    for axle in ("c_y_front", "c_y_rear"):
        lo, hi = d[axle]["hdi_90"]
        row[axle] = d[axle] | {
            "over_truth": d[axle]["mean"] / row["c_y_true"],
            "covers_truth": bool(lo <= row["c_y_true"] <= hi),
        }
    row["moments"] = _moments(obs, row["c_y_true"])
    return row


def _moments(obs, c_y_true: float) -> dict:
    """A fast fleet run's lateral step on the same observations: the in-car estimator's state
    after the drive's last block (``tyrebayes.batch.lateral``'s rule: converged, K contracted);
    its c_y is the geometric mean of the axles'."""
    estimate = online_lateral(lateral_blocks(obs), surface="dry").estimate
    usable = bool(estimate.converged) and bool(estimate.k_contracted)
    rows = [estimate.names.index("c_y_front"), estimate.names.index("c_y_rear")]
    c_y = float(np.exp(np.asarray(estimate.mean)[rows].mean()))
    return {"usable": usable, "c_y": c_y, "over_truth": c_y / c_y_true}


CASES = (("steady", True), ("steady", False), ("mixed", True), ("mixed", False))
#: The cornering simulator's white sensor noise per channel (sd, in the stream's units:
#: ``tyrebayes/simulate/cornering.py``), added one channel at a time to its noise-free drives.
CHANNEL_NOISE = {
    "ay": ("ay",),
    "yaw_rate": ("yaw_rate",),
    "steering_wheel_angle": ("steering_wheel_angle",),
    "wheel speeds": tuple(f"wheel_speed_{w}" for w in ("fl", "fr", "rl", "rr")),
}
CHANNEL_SD = {"ay": 0.05, "yaw_rate": 0.002, "steering_wheel_angle": 0.002, "wheel speeds": 0.02}


def _cornering_case(
    manoeuvre: str, noise: bool, seeds: list[int], duration_s: float, channel: str = ""
) -> dict:
    """The cornering simulator's drives of one case: c_y over the truth, coverage. With
    ``channel`` (and ``noise`` off) that channel alone gets its white noise."""
    vehicle = load_vehicle(VEHICLE)
    ratios, hits = [], []
    for seed in seeds:
        frame, truth = simulate_cornering(
            vehicle, manoeuvre=manoeuvre, duration_s=duration_s, seed=seed, noise=noise
        )
        if channel:
            rng = np.random.default_rng(seed + 1000)
            for column in CHANNEL_NOISE[channel]:
                frame[column] = frame[column] + rng.normal(0.0, CHANNEL_SD[channel], len(frame))
        d = fit_lateral(cornering_observations(frame, vehicle)).to_dict()
        for axle in ("c_y_front", "c_y_rear"):
            true = float(getattr(truth, axle))
            lo, hi = d[axle]["hdi_90"]
            ratios.append(d[axle]["mean"] / true)
            hits.append(bool(lo <= true <= hi))
    return {
        "manoeuvre": manoeuvre,
        "noise": noise,
        "noise_only_on": channel,
        "seeds": seeds,
        "c_y_over_truth": ratios,
        "covers_truth": hits,
        "median_over_truth": float(np.median(ratios)),
        "coverage_90": float(np.mean(hits)),
    }


def _median_figure(name: str, values: list[float], excluded: dict, note: str) -> dict:
    return figure(
        name,
        float(np.median(values)) if values else None,
        count=len(values),
        exclusions=excluded,
        note=note,
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8, help="drives (seeds 1..N)")
    parser.add_argument("--duration", type=float, default=600.0, help="drive length [s]")
    parser.add_argument(
        "--cornering-seeds", type=int, default=3, help="cornering-simulator drives per case"
    )
    args = parser.parse_args()
    rows = []
    for seed in range(1, args.seeds + 1):
        row = _drive(seed, args.duration)
        rows.append(row)
        print(
            seed,
            row["status"],
            {k: round(row[k]["over_truth"], 2) for k in ("c_y_front", "c_y_rear") if k in row},
            row.get("adequacy_reasons"),
            flush=True,
        )
    fitted = [r for r in rows if r["status"] == "fitted" and r["converged"]]
    excluded = {
        f"seed {r['seed']}": r.get("reason") or "lateral fit did not converge"
        for r in rows
        if r not in fitted
    }
    flagged = [r for r in fitted if not r["adequate"]]
    trusted = [r for r in fitted if r["adequate"]]
    hit = sum(r[a]["covers_truth"] for r in trusted for a in ("c_y_front", "c_y_rear"))
    ratios = [r[a]["over_truth"] for r in fitted for a in ("c_y_front", "c_y_rear")]
    moments = [r["moments"]["over_truth"] for r in fitted if r["moments"]["usable"]]
    figures = [
        figure(
            "fits flagged not adequate",
            len(flagged) / max(len(fitted), 1),
            count=len(fitted),
            exclusions=excluded,
            note=f"{len(flagged)} of {len(fitted)}; the reasons are in the drives' rows",
            headline=True,
        ),
        figure(
            "c_y 90 % interval coverage among the fits not flagged",
            hit / (2 * len(trusted)) if trusted else None,
            count=2 * len(trusted),
            exclusions=excluded,
            note=f"{hit} of {2 * len(trusted)} axle values",
            headline=True,
        ),
        _median_figure(
            "c_y over the simulated tyre's, median over axles and drives",
            ratios,
            excluded,
            "brush curve and load transfer in the truth, a Magic Formula on static loads "
            "in the fit",
        ),
        _median_figure(
            "a fast fleet run's lateral step (in-car moments): c_y over the truth, median",
            moments,
            excluded,
            "the geometric mean of the axles; drives whose estimate the fleet run would use",
        ),
        figure(
            "yaw inertia's distance from the vehicle file's, median",
            float(np.median([r["yaw_inertia_prior_sds"] for r in fitted])) if fitted else None,
            unit="prior sds",
            count=len(fitted),
            exclusions=excluded,
        ),
    ]
    seeds = list(range(21, 21 + args.cornering_seeds))
    cases = [_cornering_case(m, noise, seeds, args.duration) for m, noise in CASES]
    cases += [
        _cornering_case("steady", False, seeds, args.duration, channel) for channel in CHANNEL_NOISE
    ]
    for case in cases:
        noise = "with noise" if case["noise"] else "no noise"
        if case["noise_only_on"]:
            noise = f"noise on {case['noise_only_on']} only"
        label = f"cornering simulator, {case['manoeuvre']}, {noise}"
        print(label, round(case["median_over_truth"], 3), case["coverage_90"], flush=True)
        figures += [
            figure(
                f"{label}: c_y over the truth, median",
                case["median_over_truth"],
                count=len(case["c_y_over_truth"]),
            ),
            figure(
                f"{label}: c_y 90 % interval coverage",
                case["coverage_90"],
                count=len(case["covers_truth"]),
                note=f"{sum(case['covers_truth'])} of {len(case['covers_truth'])} axle values",
            ),
        ]
    payload = {
        "settings": {
            "vehicle": VEHICLE,
            "tyre": TYRE,
            "duration_s": args.duration,
            "sample_rate_hz": RATE_HZ,
            "seeds": list(range(1, args.seeds + 1)),
            "cornering_seeds": seeds,
        },
        "drives": rows,
        "cornering_cases": cases,
    }
    path = write_result("lateral_simulated_drives", payload, figures=figures)
    print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
