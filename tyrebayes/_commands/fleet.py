"""Fleet commands: ``fit-fleet``, ``predict`` and ``warn``.

``tyrebayes fit-fleet TABLE --outcome mu [--out FLEET.nc] [--json]`` fits the hierarchical fleet
model; it exits 3 when the fit did not converge (the fit is still written and printed, marked
``"converged": false``). ``tyrebayes predict FLEET.nc --c-xr V [--c-xr-sd SD] --type T [--json]``
gives the predictive friction of a new set; ``tyrebayes warn FLEET.nc ...`` with the same
arguments the winter-suitability verdict.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from .._domain import SURFACES, TYRE_TYPES
from .._errors import BadInputError
from ._common import (
    diagnostics_text,
    existing_file,
    exit_status,
    fit_file,
    output_file,
    print_json,
    save_fit,
)

# The library (JAX, NumPyro, pandas) is imported inside the run functions: ``tyrebayes --help``
# imports every command module to build its parser, and fit-tyre must set JAX's device count
# before any module touches a device (_common.start_jax).

_TYPES = (*TYRE_TYPES, "unknown")
#: Friction levels of the ``p_below`` output: 0.3 (deep snow/ice), 0.45 (the thesis' low-friction
#: region edge), 0.6 (wet asphalt).
P_BELOW_LEVELS = (0.3, 0.45, 0.6)


def register(subparsers: argparse._SubParsersAction) -> None:
    fit = subparsers.add_parser(
        "fit-fleet",
        help="fit the hierarchical fleet model to a fleet table",
        description="Fit friction vs inverse stiffness, pooled by tyre type, to a fleet table "
        "(CSV or Parquet: tyre_id, tyre_type, c_xr, [c_xr_sd], outcome, [surface], [c_y, c_y_sd]: "
        "a set's lateral estimate, from which the fit learns each type's ratio c_y / C_xr).",
    )
    fit.add_argument("table", help="fleet table (.csv or .parquet)")
    fit.add_argument("--outcome", default="mu", help="outcome column (default mu)")
    fit.add_argument(
        "--out",
        help="output netCDF (default TABLE stem + .fleet.nc; missing folders are created)",
    )
    fit.add_argument(
        "--method",
        choices=("nuts", "svi"),
        default=None,
        help="default: nuts up to 2,000 rows, svi above",
    )
    fit.add_argument("--seed", type=int, default=0)
    fit.add_argument("--samples", type=int, default=1000, help="NUTS draws per chain")
    fit.add_argument("--warmup", type=int, default=1000, help="NUTS warm-up steps per chain")
    fit.add_argument("--chains", type=int, default=2)
    fit.add_argument("--json", action="store_true", help="machine-readable output")
    fit.set_defaults(func=run_fit)

    for name, helptext, func in (
        ("predict", "predictive friction of a new tyre set", run_predict),
        ("warn", "winter-suitability warning for a tyre set", run_warn),
    ):
        p = subparsers.add_parser(name, help=helptext, description=helptext)
        p.add_argument("fit", help="fleet fit (.nc from fit-fleet)")
        p.add_argument("--c-xr", type=float, required=True, help="stiffness C_xr of the set")
        p.add_argument("--c-xr-sd", type=float, default=0.0, help="its standard error")
        p.add_argument("--type", choices=_TYPES, required=True, dest="tyre_type")
        p.add_argument("--surface", choices=SURFACES, default="snow")
        p.add_argument("--seed", type=int, default=0)
        p.add_argument("--json", action="store_true", help="machine-readable output")
        if name == "warn":
            p.add_argument(
                "--mu-min",
                type=float,
                default=None,
                help="minimum acceptable mu (default derived from braking data, snow)",
            )
            p.add_argument("--cost-false-alarm", type=float, default=None)
            p.add_argument("--cost-miss", type=float, default=None)
        p.set_defaults(func=func)


def _read_table(path: str):
    import pandas as pd

    p = existing_file(path)
    try:
        if p.suffix.lower() in (".parquet", ".pq"):
            return pd.read_parquet(p)
        return pd.read_csv(p)
    except (ValueError, OSError) as err:
        raise BadInputError(f"fleet table {path}: expected CSV or Parquet, got {err}") from None


def run_fit(args: argparse.Namespace) -> int:
    from ..inference.fleet import fit_fleet, fit_summary

    out = output_file(args.out or str(Path(args.table).with_suffix(".fleet.nc")))
    table = _read_table(args.table)
    if args.outcome not in table.columns:
        raise BadInputError(
            f"--outcome: expected a column of the table, got {args.outcome!r} "
            f"(columns {list(table.columns)})"
        )
    _check_c_xr_sd_column(table)
    method = args.method or ("nuts" if len(table) <= 2000 else "svi")
    for name in ("samples", "warmup", "chains"):
        if getattr(args, name) < 1:
            raise BadInputError(f"--{name}: expected >= 1, got {getattr(args, name)}")
    fit = fit_fleet(
        table,
        outcome=args.outcome,
        method=method,
        seed=args.seed,
        num_warmup=args.warmup,
        num_samples=args.samples,
        num_chains=args.chains,
        source=str(args.table),
    )
    final = save_fit(fit, out)
    summary = {"out": str(final), **fit_summary(fit)}
    if args.json:
        print_json(summary)
    else:
        print(f"fleet fit ({method}) of {summary['n_sets']} sets -> {final}")
        print(diagnostics_text(fit.diagnostics))
        for s, per_type in summary["parameters"].items():
            for t, p in per_type.items():
                a, b, sig = p["a"], p["b"], p["sigma"]
                print(
                    f"  {s:5s} {t:10s} mu@ref {a['mean']:.3f} [{a['hdi_90'][0]:.3f}, "
                    f"{a['hdi_90'][1]:.3f}]  slope {b['mean']:+.3f}  sigma {sig['mean']:.3f}"
                )
        for t, r in (summary["lateral_ratio"] or {}).items():
            k = r["median_ratio"]
            print(
                f"  c_y/C_xr {t:10s} {k['mean']:.3f} [{k['hdi_90'][0]:.3f}, "
                f"{k['hdi_90'][1]:.3f}]  from {r['from']} ({r['n_sets']} sets)"
            )
    return exit_status(fit, "fit-fleet")


def _check_c_xr_sd_column(table) -> None:
    """``c_xr_sd``: finite, positive and no larger than the stiffness it qualifies.

    A standard error above the value itself says the stiffness was not measured; 1e300 ran
    the sampler into 2,000 divergences and exit 3 where ``c_xr`` itself is range-checked.
    Rows whose ``c_xr`` is missing or unusable are left to the fleet table's own checks.
    """
    import pandas as pd

    if "c_xr_sd" not in table.columns or "c_xr" not in table.columns:
        return
    sd = pd.to_numeric(table["c_xr_sd"], errors="coerce").to_numpy(float)
    c_xr = pd.to_numeric(table["c_xr"], errors="coerce").to_numpy(float)
    usable = np.isfinite(c_xr) & (c_xr > 0)
    with np.errstate(invalid="ignore"):
        bad = usable & ~(np.isfinite(sd) & (sd > 0) & (sd <= c_xr))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise BadInputError(
            f"c_xr_sd: expected a standard error in (0, c_xr], got {table['c_xr_sd'].iloc[k]!r} "
            f"for c_xr {c_xr[k]:g} in data row {k + 1} ({int(bad.sum())} such rows)"
        )


def _check_c_xr(args) -> str | None:
    if not (math.isfinite(args.c_xr) and args.c_xr > 0):
        raise BadInputError(f"--c-xr: expected a positive stiffness, got {args.c_xr}")
    if not (math.isfinite(args.c_xr_sd) and 0 <= args.c_xr_sd <= args.c_xr):
        raise BadInputError(
            f"--c-xr-sd: expected a standard error in [0, --c-xr] ({args.c_xr:g}), "
            f"got {args.c_xr_sd:g}"
        )
    return None if args.tyre_type == "unknown" else args.tyre_type


def _informing_c_xr(fit, surface: str, tyre_type: str | None) -> tuple[np.ndarray, str]:
    """Measured C_xr of the sets that inform a prediction, and those sets in words.

    The sets with an outcome on ``surface`` (all sets for a surface without data), narrowed to
    ``tyre_type`` when at least two of that type are among them: the slope is per type, so its
    range is the type's; with fewer the slope leans on the other types (partial pooling).
    """
    const = fit.data["constant_data"]
    c_xr = np.asarray(const["c_xr_obs"], float)
    tyre_types = np.asarray(const["tyre_type_index"], int)
    row_tyre = np.asarray(const["row_tyre"], int)
    sets = np.unique(row_tyre[np.asarray(const["row_surface"]) == SURFACES.index(surface)])
    where = f" on {surface}" if sets.size else ""
    if not sets.size:
        sets = np.arange(c_xr.size)
    of_type = ""
    if tyre_type is not None:
        same = sets[tyre_types[sets] == TYRE_TYPES.index(tyre_type)]
        if same.size >= 2:
            sets, of_type = same, f"{tyre_type} "
    return c_xr[sets], f"the fleet's {of_type}sets{where}"


def prediction(args: argparse.Namespace) -> tuple[np.ndarray, dict]:
    """Predictive draws and the JSON of ``predict`` for parsed arguments."""
    from .. import decisions
    from ..inference.fleet import predict_friction
    from ..inference.result import load_fit
    from ..inference.summary import summarize

    tyre_type = _check_c_xr(args)
    fit = load_fit(fit_file(args.fit, "a fleet fit (netCDF from fit-fleet)"), kind="fleet")
    draws = predict_friction(fit, args.c_xr, args.c_xr_sd, tyre_type, args.surface, seed=args.seed)
    fitted = fit.attr("fitted_surfaces")
    extrapolation = decisions.stiffness_extrapolation(
        args.c_xr, *_informing_c_xr(fit, args.surface, tyre_type)
    )
    payload = {
        "mu": summarize(draws).to_dict(),
        "p_below": {f"{lvl:g}": float(np.mean(draws < lvl)) for lvl in P_BELOW_LEVELS},
        "surface": args.surface,
        "tyre_type": args.tyre_type,
        "c_xr": args.c_xr,
        "c_xr_sd": args.c_xr_sd,
        "prior_only": args.surface not in fitted,
        **extrapolation,
        "fit_converged": fit.converged,
        "fit_adequate": fit.adequate,
    }
    return draws, payload


def run_predict(args: argparse.Namespace) -> int:
    _, payload = prediction(args)
    if args.json:
        print_json(payload)
    else:
        mu = payload["mu"]
        note = " (prior only: no data on this surface)" if payload["prior_only"] else ""
        print(
            f"mu on {args.surface}: {mu['mean']:.3f} +- {mu['sd']:.3f}, 90% HDI "
            f"[{mu['hdi_90'][0]:.3f}, {mu['hdi_90'][1]:.3f}]{note}"
        )
        for lvl, p in payload["p_below"].items():
            print(f"  P(mu < {lvl}) = {p:.3f}")
        if payload["extrapolation"]:
            print(f"note: {payload['extrapolation_note']}")
    return 0


def run_warn(args: argparse.Namespace) -> int:
    from .. import decisions

    if args.mu_min is not None:
        decisions.check_mu_min(args.mu_min, "--mu-min")  # before the fit is loaded
    if args.mu_min is None and args.surface != "snow":
        raise BadInputError(
            f"--mu-min: expected a value for surface {args.surface!r} (a default exists only for "
            "snow), got none"
        )
    mu_min = decisions.DEFAULT_MU_MIN_SNOW if args.mu_min is None else args.mu_min
    c_fa = (
        decisions.DEFAULT_COST_FALSE_ALARM
        if args.cost_false_alarm is None
        else args.cost_false_alarm
    )
    c_miss = decisions.DEFAULT_COST_MISS if args.cost_miss is None else args.cost_miss
    draws, pred = prediction(args)
    verdict = decisions.winter_verdict(
        draws, mu_min=mu_min, cost_false_alarm=c_fa, cost_miss=c_miss
    ).to_dict()
    verdict.update(
        {
            k: pred[k]
            for k in (
                "surface",
                "tyre_type",
                "c_xr",
                "c_xr_sd",
                "prior_only",
                "extrapolation",
                "c_xr_range",
                "extrapolation_note",
                "fit_converged",
                "fit_adequate",
            )
        }
    )
    if args.json:
        print_json(verdict)
    else:
        print(f"{verdict['verdict']}: {verdict['reason']}")
        if verdict["extrapolation"]:
            print(f"note: {verdict['extrapolation_note']}")
    return 0
