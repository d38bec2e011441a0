"""The fleet's per-type ratio c_y / C_xr: recovered on simulated fleets, and a straight-only V_max.

Run: ``python benchmarks/fleet_lateral_ratio.py [--seeds N] [--no-e2e] [--lateral-method M]``. Saves
``benchmarks/results/fleet_lateral_ratio.json``.

1. Table level (``--seeds`` fleets): :func:`tyrebayes.simulate.fleet.simulate_fleet` with known
   per-type ratios :data:`TRUE_RATIO` (median k, within-type log-sd), deliberately away from the
   lane change's fixed k_type (0.45 / 0.40 / 0.35) for winter and summer; 90 snow sets (type mix
   40/30/30 %), 70 % of them with a measured c_y of relative error 0.06-0.15 (the per-drive
   lateral fits' relative sds are 0.1-0.15, ``lateral_external.json``; a set of several drives
   is tighter), the rest driven only straight. :func:`tyrebayes.fit_fleet` (NUTS at its
   defaults) per fleet. Figures: the 90 % interval (HDI) of each type's median ratio exp(k_loc)
   covers the truth, over seeds and types (target ≥ 0.9 nominal); and, for one straight-only set
   of each type per fleet, whether the 90 % interval of its predictive V_max
   (:func:`tyrebayes.inference.vmax.fleet_ratio_vmax_inputs`: k from the fleet's posterior
   predictive times the set's C_xr, measured with its sd) covers the V_max of its true c_y
   = k_i · C_true_i and a true μ_y drawn from the type relation (the prediction's μ_y is the
   type relation's, so μ_y's part is well specified: the figure tests the ratio's part); again
   with μ_y at the truth in both (the c_y's share alone); and the fixed k_type relation's
   coverage of the same sets for comparison.
2. End to end (one fleet, unless ``--no-e2e``): 4 lateral sets of each type get a simulated
   three-minute mixed cornering drive (:func:`tyrebayes.simulate.cornering.simulate_cornering`,
   axles at 0.9 c and c / 0.9 of the set's true c = k_i · C_true_i) fitted by the fleet run's
   own per-drive step (:func:`tyrebayes.batch.lateral.drive_lateral`: cornering observations and
   the lateral fit of ``--lateral-method``, by default a fast run's, the in-car estimator's
   moments); only these 12 sets carry c_y. Figures: the sets' c_y 90 % intervals
   cover the truth, and the fleet's type ratios cover theirs. The cornering simulator shares the
   lateral model's assumptions (a test of the code path, not of the method).

Counts: sets, seeds, fits not converged (left out of the coverage, named in the exclusions).
Timings come from a shared 2-core machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpyro
from _results import figure, write_result  # noqa: E402

numpyro.set_host_device_count(2)

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from _internal import LATERAL_METHODS, drive_lateral  # noqa: E402

from tyrebayes import TYRE_TYPES, RunSettings, fit_fleet, load_vehicle, summarize  # noqa: E402
from tyrebayes.inference.vmax import (  # noqa: E402
    MU_TYPE,
    MU_Y_RATIO,
    fleet_ratio_vmax_inputs,
    predict_vmax,
    range_counts,
    type_vmax_inputs,
    vmax_draws,
)
from tyrebayes.simulate import simulate_cornering, simulate_fleet  # noqa: E402

#: Per type: (median c_y / C_xr, within-type log-sd) of the simulated fleets.
TRUE_RATIO = {"winter": (0.52, 0.10), "all_season": (0.38, 0.10), "summer": (0.30, 0.10)}
SHARES = {"winter": 0.4, "all_season": 0.3, "summer": 0.3}
N_SETS = 90
LATERAL_SHARE = 0.7
C_Y_LOG_SD = (0.06, 0.15)
VEHICLE = "compact_fwd"
N_DRAWS = 400
E2E_SETS_PER_TYPE = 4
E2E_DURATION_S = 180.0
TRUTH_TOL_MPS = 0.02


def _covered(draws: np.ndarray, truth: float) -> dict:
    """Summary of ``draws`` and whether its 90 % interval covers ``truth``; for V_max draws
    ``not_bracketed`` counts those beyond the search range too (kept at its ends, in the
    summary) beside the undefined ones (left out)."""
    s = summarize(draws).to_dict()
    lo, hi = s["hdi_90"]
    beyond = range_counts(draws)
    return {**s, "covered": bool(lo <= truth <= hi), "not_bracketed": sum(beyond.values())}


def _ratio_rows(fit, truth_ratio: dict) -> list[dict]:
    rows = []
    for i, t in enumerate(TYRE_TYPES):
        med = np.exp(fit.draws("k_loc")[:, i])
        rows.append(
            {"tyre_type": t, "truth": truth_ratio[t][0], **_covered(med, truth_ratio[t][0])}
        )
    return rows


def _true_vmax(vehicle, c_y: float, mu_y: float) -> float:
    v = vmax_draws(vehicle, np.array([c_y]), np.array([mu_y]), tol_mps=TRUTH_TOL_MPS)
    return float(np.asarray(v)[0])


def _straight_sets(table, truth, fit, vehicle, key, rng) -> list[dict]:
    """One straight-only set of each type: V_max interval from the fleet ratio and from k_type."""
    first = table.drop_duplicates("tyre_id").set_index("tyre_id")
    rows = []
    for j, t in enumerate(TYRE_TYPES):
        idx = [
            i
            for i in range(len(truth["k_true"]))
            if not truth["has_lateral"][i] and first.loc[f"T{i:05d}", "tyre_type"] == t
        ]
        if not idx:
            continue
        i = idx[0]
        rec = first.loc[f"T{i:05d}"]
        c_y_true = float(truth["c_y_true"][i])
        mu_true = MU_Y_RATIO * (MU_TYPE[t] + 0.05 * rng.standard_normal())
        v_true = _true_vmax(vehicle, c_y_true, mu_true)
        c_xr_draws = np.maximum(rec["c_xr"] + rec["c_xr_sd"] * rng.standard_normal(N_DRAWS), 1.0)
        k1, k2 = jax.random.split(jax.random.fold_in(key, j))
        fleet_in = fleet_ratio_vmax_inputs(k1, fit, c_xr_draws, t, N_DRAWS)
        type_in = type_vmax_inputs(k2, c_xr_draws, t, N_DRAWS)
        row = {
            "tyre_id": f"T{i:05d}",
            "tyre_type": t,
            "c_y_true": c_y_true,
            "k_true": float(truth["k_true"][i]),
            "mu_y_true": mu_true,
            "v_max_true_kmh": v_true,
            "c_y_fleet": summarize(fleet_in.c_y_front).to_dict(),
            "c_y_type": summarize(type_in.c_y_front).to_dict(),
        }
        if not np.isfinite(v_true):
            row["excluded"] = "true-parameter V_max not bracketed"
            rows.append(row)
            continue
        mu_at_truth = np.full(N_DRAWS, mu_true)
        for name, inputs in (("fleet_type_ratio", fleet_in), ("type_prior", type_in)):
            row[name] = _covered(predict_vmax(vehicle, inputs).v_max_kmh, v_true)
            fixed = dataclasses.replace(inputs, mu_y=mu_at_truth)
            row[name + "_mu_y_at_truth"] = _covered(predict_vmax(vehicle, fixed).v_max_kmh, v_true)
        rows.append(row)
    return rows


def _table_level(seeds: list[int], vehicle) -> list[dict]:
    out = []
    for seed in seeds:
        table, truth = simulate_fleet(
            seed,
            N_SETS,
            type_shares=SHARES,
            lateral_ratio=TRUE_RATIO,
            lateral_share=LATERAL_SHARE,
            c_y_log_sd=C_Y_LOG_SD,
        )
        start = time.perf_counter()
        fit = fit_fleet(table, seed=seed)
        seconds = time.perf_counter() - start
        d = fit.diagnostics
        rng = np.random.default_rng(1000 + seed)
        row = {
            "seed": seed,
            "sets": int(len(truth["k_true"])),
            "lateral_sets": int(np.sum(truth["has_lateral"])),
            "fit_seconds": seconds,
            "converged": bool(d.converged),
            "reasons": list(d.reasons),
            "ratios": _ratio_rows(fit, TRUE_RATIO),
            "straight_sets": _straight_sets(
                table, truth, fit, vehicle, jax.random.PRNGKey(seed), rng
            ),
        }
        out.append(row)
        cov = [r["covered"] for r in row["ratios"]]
        print(
            f"seed {seed}: {seconds:.0f} s, converged {row['converged']}, ratio covered {cov}, "
            + ", ".join(
                f"{r['tyre_type']} {r['mean']:.3f} [{r['hdi_90'][0]:.3f}, {r['hdi_90'][1]:.3f}]"
                for r in row["ratios"]
            ),
            flush=True,
        )
    return out


def _end_to_end(seed: int, vehicle, method: str) -> dict:
    table, truth = simulate_fleet(
        seed, N_SETS, type_shares=SHARES, lateral_ratio=TRUE_RATIO, lateral_share=LATERAL_SHARE
    )
    first = table.drop_duplicates("tyre_id").set_index("tyre_id")
    chosen = {t: [] for t in TYRE_TYPES}
    for i in range(len(truth["k_true"])):
        t = first.loc[f"T{i:05d}", "tyre_type"]
        if truth["has_lateral"][i] and len(chosen[t]) < E2E_SETS_PER_TYPE:
            chosen[t].append(i)
    table["c_y"] = np.nan
    table["c_y_sd"] = np.nan
    sets = []
    for t, idx in chosen.items():
        for i in idx:
            c = float(truth["c_y_true"][i])
            frame, _ = simulate_cornering(
                vehicle,
                manoeuvre="mixed",
                duration_s=E2E_DURATION_S,
                seed=seed * 100 + i,
                c_y_front=0.9 * c,
                c_y_rear=c / 0.9,
            )
            start = time.perf_counter()
            lat = drive_lateral(frame, vehicle, "dry", method=method, seed=i)
            row = {"tyre_id": f"T{i:05d}", "tyre_type": t, "c_y_true": c,
                   "seconds": time.perf_counter() - start, **lat}  # fmt: skip
            if lat["lateral_reason"]:
                row["covered"] = None
            else:
                z = 1.645 * lat["c_y_log_sd"]
                lo, hi = lat["c_y"] * np.exp(-z), lat["c_y"] * np.exp(z)
                row["covered"] = bool(lo <= c <= hi)
                row["rel_error"] = lat["c_y"] / c - 1.0
                mask = table["tyre_id"] == f"T{i:05d}"
                table.loc[mask, "c_y"] = lat["c_y"]
                table.loc[mask, "c_y_sd"] = lat["c_y"] * lat["c_y_log_sd"]
            sets.append(row)
            print(f"e2e {row['tyre_id']} {t}: {row.get('rel_error', np.nan):+.3%} "
                  f"{lat['lateral_reason']} ({row['seconds']:.1f} s)", flush=True)  # fmt: skip
    fit = fit_fleet(table, seed=seed)
    return {
        "seed": seed,
        "sets": int(len(truth["k_true"])),
        "lateral_sets": sum(1 for s in sets if not s["lateral_reason"]),
        "cornering_drive_s": E2E_DURATION_S,
        "converged": bool(fit.converged),
        "reasons": list(fit.diagnostics.reasons),
        "lateral_fits": sets,
        "ratios": _ratio_rows(fit, TRUE_RATIO),
    }


def _coverage_figure(name, hits, excluded, note="", target=(">=", 0.9)):
    n = len(hits)
    value = float(np.mean(hits)) if n else None
    return figure(
        name,
        value,
        target=target,
        count=n,
        exclusions=excluded,
        note=note or f"{sum(hits)} of {n}",
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20, help="simulated fleets (table level)")
    parser.add_argument("--no-e2e", action="store_true", help="skip the end-to-end case")
    parser.add_argument(
        "--lateral-method",
        choices=LATERAL_METHODS,
        default=RunSettings().lateral_method,
        help="the end-to-end drives' lateral fit (default: a fast fleet run's)",
    )
    args = parser.parse_args()
    vehicle = load_vehicle(VEHICLE)
    seeds = list(range(1, args.seeds + 1))
    fleets = _table_level(seeds, vehicle)
    e2e = None if args.no_e2e else _end_to_end(101, vehicle, args.lateral_method)

    not_converged = {
        f"seed {f['seed']}": "; ".join(f["reasons"]) for f in fleets if not f["converged"]
    }
    ok = [f for f in fleets if f["converged"]]
    ratio_hits = [r["covered"] for f in ok for r in f["ratios"]]
    per_type = {
        t: [r["covered"] for f in ok for r in f["ratios"] if r["tyre_type"] == t]
        for t in TYRE_TYPES
    }
    straight = [s for f in ok for s in f["straight_sets"]]
    straight_excl = {
        f"seed {f['seed']} {s['tyre_id']}": s["excluded"]
        for f in ok
        for s in f["straight_sets"]
        if "excluded" in s
    }
    used = [s for s in straight if "excluded" not in s]
    excl_all = {**not_converged, **straight_excl}

    def hits(key):
        return [s[key]["covered"] for s in used]

    figures = [
        _coverage_figure(
            "type median ratio c_y / C_xr: 90 % interval covers the truth, all types",
            ratio_hits,
            not_converged,
            note=f"{sum(ratio_hits)} of {len(ratio_hits)} intervals ({len(ok)} converged fleets "
            f"of {len(fleets)}, {N_SETS} sets each, {LATERAL_SHARE:.0%} with c_y); binomial "
            f"sd of a true 0.9 over {len(ratio_hits)}: "
            f"{np.sqrt(0.09 / max(len(ratio_hits), 1)):.3f}",
        ),
        *[
            _coverage_figure(
                f"type median ratio 90 % coverage, {t} (truth {TRUE_RATIO[t][0]:g})",
                per_type[t],
                not_converged,
            )
            for t in TYRE_TYPES
        ],
        _coverage_figure(
            "straight-only set: V_max 90 % interval from the fleet ratio covers the true V_max",
            hits("fleet_type_ratio"),
            excl_all,
            note=f"{sum(hits('fleet_type_ratio'))} of {len(used)} sets (one per type and "
            "fleet); μ_y from the type relation in truth and prediction",
        ),
        _coverage_figure(
            "same with μ_y at the truth (the c_y's share)",
            hits("fleet_type_ratio_mu_y_at_truth"),
            excl_all,
        ),
        _coverage_figure(
            "fixed k_type relation: V_max 90 % coverage of the same sets (comparison)",
            hits("type_prior"),
            excl_all,
            target=None,
        ),
        _coverage_figure(
            "fixed k_type relation with μ_y at the truth (comparison)",
            hits("type_prior_mu_y_at_truth"),
            excl_all,
            target=None,
        ),
        figure(
            "fleet fits not converged",
            len(not_converged),
            target=("==", 0),
            count=len(fleets),
            exclusions=not_converged,
        ),
    ]
    if e2e is not None:
        fits_ok = [s for s in e2e["lateral_fits"] if s["covered"] is not None]
        no_fit = {
            s["tyre_id"]: s["lateral_reason"] for s in e2e["lateral_fits"] if s["covered"] is None
        }
        figures += [
            _coverage_figure(
                "end to end: per-set c_y 90 % interval (drive_lateral) covers the truth",
                [s["covered"] for s in fits_ok],
                no_fit,
                note=f"{sum(s['covered'] for s in fits_ok)} of {len(fits_ok)} simulated "
                f"{E2E_DURATION_S:g} s cornering drives; median |error| "
                f"{100 * np.median([abs(s['rel_error']) for s in fits_ok]):.2f} %",
            ),
            _coverage_figure(
                "end to end: type median ratio 90 % coverage (one fleet, 4 cornering sets a type)",
                [r["covered"] for r in e2e["ratios"]],
                {} if e2e["converged"] else {"fleet": "; ".join(e2e["reasons"])},
                target=None,
            ),
        ]
    write_result(
        "fleet_lateral_ratio",
        {
            "true_ratio": TRUE_RATIO,
            "settings": {
                "n_sets": N_SETS,
                "lateral_share": LATERAL_SHARE,
                "c_y_log_sd": C_Y_LOG_SD,
                "type_shares": SHARES,
                "vehicle": VEHICLE,
                "v_max_draws": N_DRAWS,
                "seeds": seeds,
                "fit": "fit_fleet NUTS at its defaults",
                "end_to_end": None
                if e2e is None
                else f"cornering simulation + drive_lateral (method {args.lateral_method})",
                "machine": "shared 2-core machine (other jobs running)",
            },
            "counts": {
                "seeds": len(fleets),
                "sets_per_fleet": N_SETS,
                "fits_not_converged": len(not_converged),
                "ratio_intervals": len(ratio_hits),
                "straight_sets": len(used),
            },
            "fleets": fleets,
            "end_to_end": e2e,
        },
        figures=figures,
    )


if __name__ == "__main__":
    main()
