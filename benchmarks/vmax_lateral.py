"""V_max from the car's own cornering, on the external cornering drives (``external_lateral``).

The drives are in ``../shared/data/external_lateral``: 8 ten-minute drives from a generator written
apart from the package (a two-track car on load-dependent Magic Formula tyres, roll, bank, a
steering ratio and offset the vehicle file does not give), with each drive's true c_y front and
rear (over the static axle load) and μ_y in ``truth.json``. For validation, not tuning: nothing in
the package is fitted to them.

Per drive:

1. the lateral fit as ``fit-tyre`` makes it (``validate_stream`` → ``cornering_observations`` →
   ``fit_lateral``, Laplace, on the drive's surface);
2. the predictive V_max of the ISO 3888-2 lane change from its posterior
   (:func:`tyrebayes.inference.vmax.lateral_vmax_inputs` → ``predict_vmax``): the per-axle c_y at
   joint posterior draws, μ_y the fit's where it observed the peak; else, as no longitudinal
   fit is made here (no μ_max to fall back on), the prior the type-constant prediction of step 4
   takes (0.95 μ_type of the same all-season tyre) on dry drives and the surface's prior on the
   others, conditioned on the forces the drive used;
3. the "true-parameter" V_max: the same lane-change simulation, on the drive's vehicle, with the
   drive's true c_y front/rear and μ_y (:class:`tyrebayes.physics.lanechange.AxleTyres`);
4. the type-constant prediction the package makes without a lateral fit
   (:func:`~tyrebayes.inference.vmax.type_vmax_inputs`): an all-season tyre at C_xr = 35 (the
   per-tyre model's prior median, mid-range of the thesis' Table 6.2), taken as a known value, so
   its interval is the type relations' spread alone (k ~ LogNormal(log 0.40, 0.15), μ_y = 0.95 ·
   Normal(1.00, 0.05)) and as narrow as that path can be. The type relations describe dry
   asphalt: on a drive on another surface the comparison takes that surface's μ prior (the
   prior the posterior path falls back on, without the drive's forces), so that both intervals
   are of V_max on the same road;
5. the same two with μ_y fixed at the truth: how much of the width is the cornering stiffness.

The truth's axle stiffnesses in N/rad are checked against c_y · m g l_r / L and c_y · m g l_f / L
on the drive's vehicle (the conversion :class:`AxleTyres` makes).

Usage: ``python benchmarks/vmax_lateral.py [DIR] [--drives l00,l01] [--draws N]``.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter
from pathlib import Path

import jax
from _data import EXTERNAL_LATERAL, Drive, external_lateral_drives  # noqa: E402
from _results import figure, write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from tyrebayes import (  # noqa: E402
    cornering_observations,
    critical_speed,
    fit_lateral,
    lateral_vmax_inputs,
    predict_vmax,
    summarize,
    type_vmax_inputs,
    vmax_draws,
)
from tyrebayes.inference.vmax import (  # noqa: E402
    VmaxInputs,
    range_counts,
    surface_mu_y_draws,
)
from tyrebayes.physics import AxleTyres  # noqa: E402

#: The type-constant comparison's tyre: the per-tyre model's C_xr prior median (TyrePriors).
TYPE_C_XR = 35.0
TYPE_TYRE = "all_season"
#: Bisection tolerance of the true-parameter V_max [m/s] (the predictions use the package's 0.1).
TRUTH_TOL_MPS = 0.02


def _interval(draws_kmh: np.ndarray, truth_kmh: float) -> dict:
    s = summarize(draws_kmh).to_dict()
    beyond = range_counts(draws_kmh)
    lo, hi = s["hdi_90"]
    return {
        **s,
        "width": hi - lo,
        "covered": bool(lo <= truth_kmh <= hi),
        "error": s["mean"] - truth_kmh,
        # draws beyond the search range are in the summary at its ends (predict_vmax)
        "not_bracketed": sum(beyond.values()),
        **beyond,
    }


def _on_surface(typed: VmaxInputs, surface: str, key) -> VmaxInputs:
    """The type-constant inputs with μ_y from ``surface``'s prior (the type relations' μ_y is
    dry asphalt's)."""
    mu = surface_mu_y_draws(key, surface, typed.n_draws)
    note = f"type relations' c_y; mu_y the {surface} prior (the relations' is dry asphalt's)"
    return VmaxInputs(
        typed.c_y_front, typed.c_y_rear, mu, "type_prior", "surface_prior", surface, note
    )


def _drive(drive: Drive, n: int, key) -> dict:
    name, truth = drive.path.name, drive.truth
    vehicle = drive.vehicle()
    # the conversion to N/rad on this vehicle against the generator's own
    tyres = AxleTyres(truth["c_y_front"], truth["c_y_rear"], truth["mu_y"])
    c_f, c_r = tyres.cornering_stiffness_n_per_rad(vehicle)
    conversion = max(
        abs(float(c_f) / truth["cornering_stiffness_front_n_per_rad"] - 1.0),
        abs(float(c_r) / truth["cornering_stiffness_rear_n_per_rad"] - 1.0),
    )
    cs = critical_speed(vehicle, tyres, tol_mps=TRUTH_TOL_MPS)
    v_true = 0.5 * float(cs.v_max_mps + cs.v_fail_mps) * 3.6

    validated = drive.validated(vehicle)
    obs = cornering_observations(validated.data, vehicle)
    start = time.perf_counter()
    fit = fit_lateral(obs, surface=truth["surface"], inputs=(name,))
    fit_s = time.perf_counter() - start
    d = fit.to_dict()

    k_post, k_type = jax.random.split(key)
    inputs = lateral_vmax_inputs(k_post, fit, n, tyre_type=TYPE_TYRE)
    post = predict_vmax(vehicle, inputs, vehicle_name=truth["vehicle"])
    typed_inputs = type_vmax_inputs(k_type, TYPE_C_XR, TYPE_TYRE, n)
    if truth["surface"] != "dry":
        typed_inputs = _on_surface(typed_inputs, truth["surface"], jax.random.fold_in(k_type, 1))
    typed = predict_vmax(vehicle, typed_inputs, vehicle_name=truth["vehicle"])
    # μ_y at the truth for both: the width the cornering stiffness leaves
    mu_true = jnp.full(n, truth["mu_y"])
    post_mu_true = np.asarray(
        vmax_draws(vehicle, inputs.c_y_front, mu_true, c_y_rear=inputs.c_y_rear)
    )
    typed_mu_true = np.asarray(vmax_draws(vehicle, typed_inputs.c_y_front, mu_true))
    row = {
        "drive": name,
        "kind": truth["kind"],
        "vehicle": truth["vehicle"],
        "surface": truth["surface"],
        "truth": {
            "c_y_front": truth["c_y_front"],
            "c_y_rear": truth["c_y_rear"],
            "mu_y": truth["mu_y"],
            "mu_y_observed": truth["mu_y_observed"],
            "v_max_kmh": v_true,
            "bracketed": bool(cs.bracketed),
        },
        "conversion_rel_error": conversion,
        "fit": {
            "converged": d["converged"],
            "convergence_reasons": list(fit.fit.diagnostics.reasons),
            "adequate": d["adequate"],
            "identified": d["identified"],
            "mu_y_observed": d["mu_y_observed"],
            "c_y_front": d["c_y_front"],
            "c_y_rear": d["c_y_rear"],
            "front_rear_correlation": d["front_rear_correlation"],
            "seconds": fit_s,
        },
        "posterior": {
            **_interval(post.v_max_kmh, v_true),
            "lateral_source": inputs.lateral_source,
            "mu_y_source": inputs.mu_y_source,
            "mu_y": summarize(inputs.mu_y).to_dict(),
            "note": inputs.note,
        },
        "type_constant": {
            **_interval(typed.v_max_kmh, v_true),
            "c_y": summarize(typed_inputs.c_y_front).to_dict(),
            "mu_y": summarize(typed_inputs.mu_y).to_dict(),
            "mu_y_source": typed_inputs.mu_y_source,
        },
        "mu_y_at_truth": {
            "posterior": _interval(post_mu_true, v_true),
            "type_constant": _interval(typed_mu_true, v_true),
        },
    }
    if not cs.bracketed:
        # below 8 m/s the coasting car does not reach the course's end in the simulation's
        # fixed step count, so every run fails: V_max under 29 km/h cannot be resolved
        row["excluded"] = (
            f"true-parameter V_max not bracketed (below the simulation's 29 km/h floor; "
            f"μ_y {truth['mu_y']:.2f} on {truth['surface']}); "
            f"{row['posterior']['not_bracketed']} of {n} posterior draws also not bracketed"
        )
    row["narrower"] = row["posterior"]["width"] < row["type_constant"]["width"]
    row["width_ratio"] = row["posterior"]["width"] / row["type_constant"]["width"]
    return row


def _share(rows: list[dict], test) -> tuple[int, int]:
    hits = [bool(test(r)) for r in rows]
    return sum(hits), len(hits)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=EXTERNAL_LATERAL)
    parser.add_argument("--drives", default="", help="comma-separated drive names (default all)")
    parser.add_argument("--draws", type=int, default=1000, help="V_max draws per prediction")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    key = jax.random.PRNGKey(args.seed)
    rows = []
    for i, drive in enumerate(external_lateral_drives(args.folder, args.drives)):
        name = drive.path.name
        row = _drive(drive, args.draws, jax.random.fold_in(key, i))
        rows.append(row)
        p, t = row["posterior"], row["type_constant"]
        print(
            f"{name} {row['surface']:4s} true V_max {row['truth']['v_max_kmh']:.1f} | posterior "
            f"{p['mean']:.1f} [{p['hdi_90'][0]:.1f}, {p['hdi_90'][1]:.1f}] covered {p['covered']} "
            f"({p['mu_y_source']}) | type [{t['hdi_90'][0]:.1f}, {t['hdi_90'][1]:.1f}] "
            f"covered {t['covered']} | width ratio {row['width_ratio']:.2f}",
            flush=True,
        )
    excluded = {r["drive"]: r["excluded"] for r in rows if "excluded" in r}
    excluded.update(
        {
            r["drive"]: "lateral fit not converged: " + "; ".join(r["fit"]["convergence_reasons"])
            for r in rows
            if not r["fit"]["converged"]
        }
    )
    used = [r for r in rows if r["drive"] not in excluded]
    # the not-converged fits' predictions, for the record (their intervals are not trusted)
    unconverged = [r for r in rows if not r["fit"]["converged"] and "excluded" not in r]
    unconverged_covered = [r["drive"] for r in unconverged if r["posterior"]["covered"]]
    covered, n = _share(used, lambda r: r["posterior"]["covered"])
    bracketed = [r for r in rows if r["truth"]["bracketed"]]
    type_covered, n_all = _share(bracketed, lambda r: r["type_constant"]["covered"])
    narrower, _ = _share(used, lambda r: r["narrower"])
    ratio = float(np.median([r["width_ratio"] for r in used])) if used else None
    ratio_mu_true = (
        float(
            np.median(
                [
                    r["mu_y_at_truth"]["posterior"]["width"]
                    / r["mu_y_at_truth"]["type_constant"]["width"]
                    for r in used
                ]
            )
        )
        if used
        else None
    )
    mu_sources = Counter(r["posterior"]["mu_y_source"] for r in used)
    not_bracketed = sum(r["posterior"]["not_bracketed"] for r in rows)
    figures = [
        figure(
            "V_max 90 % interval from the lateral posterior covers the true-parameter V_max",
            covered / max(n, 1),
            target=(">=", 0.8),
            count=n,
            exclusions=excluded,
            note=f"{covered} of {n} drives; μ_y by source: "
            + ", ".join(f"{k} {v}" for k, v in sorted(mu_sources.items()))
            + f"; not converged and left out: {len(unconverged)}, of which covered: "
            f"{', '.join(unconverged_covered) or 'none'}",
            headline=True,
        ),
        figure(
            "drives whose posterior V_max interval is narrower than the type-constant one",
            narrower / max(n, 1),
            target=("==", 1.0),
            count=n,
            exclusions=excluded,
            note=f"{narrower} of {n}; type constants: {TYPE_TYRE} at C_xr {TYPE_C_XR:g} (known)",
            headline=True,
        ),
        figure(
            "median V_max interval width, posterior over type-constant",
            ratio,
            target=("<", 1.0),
            count=n,
            exclusions=excluded,
        ),
        figure(
            "same with μ_y at the truth for both (the cornering stiffness' share)",
            ratio_mu_true,
            count=n,
            exclusions=excluded,
            note="measured per-axle c_y against k_type · C_xr on both axles",
        ),
        figure(
            "type-constant V_max 90 % interval covers the true-parameter V_max",
            type_covered / max(n_all, 1),
            count=n_all,
            note=f"{type_covered} of {n_all} drives whose true V_max was bracketed "
            "(μ_y: the type relation on dry drives, the surface prior on the others)",
        ),
        figure(
            "posterior V_max median |error|",
            float(np.median([abs(r["posterior"]["error"]) for r in used])) if used else None,
            unit="km/h",
            count=n,
            exclusions=excluded,
        ),
        figure(
            "type-constant V_max median |error|",
            float(np.median([abs(r["type_constant"]["error"]) for r in bracketed])),
            unit="km/h",
            count=n_all,
        ),
        figure(
            "posterior V_max draws not bracketed (29-162 km/h)",
            not_bracketed,
            count=len(rows) * args.draws,
            note="all drives; a drive whose truth is below the floor is left out of the figures",
        ),
        figure(
            "lateral fits not converged",
            sum(not r["fit"]["converged"] for r in rows),
            target=("==", 0),
            count=len(rows),
            note=", ".join(r["drive"] for r in rows if not r["fit"]["converged"]),
        ),
        figure(
            "c_y → N/rad conversion against the generator's (max relative difference)",
            max(r["conversion_rel_error"] for r in rows),
            target=("<=", 1e-3),
            count=2 * len(rows),
            note="the generator's N/rad use g = 9.81, the package's 9.80665 (3.4e-4)",
        ),
    ]
    payload = {
        "folder": str(args.folder),
        "draws_per_prediction": args.draws,
        "type_constant_tyre": {"tyre_type": TYPE_TYRE, "c_xr": TYPE_C_XR},
        "truth_tolerance_kmh": TRUTH_TOL_MPS * 3.6,
        "drives": rows,
    }
    path = write_result("vmax_lateral", payload, figures=figures)
    for f in figures:
        print(f"{f['name']}: {f['value']} (target {f['target']}, met {f['met']})")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
