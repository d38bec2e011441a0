"""``tyrebayes fit-wear DRIVES... --vehicle V [--tread-depth READINGS.csv] [--out FIT] [--json]``.

Tread wear of one car from its own drive history: the abrasability γ (and its temperature
sensitivity κ) with the predicted tread depth, the distance to 3 mm and 1.6 mm and the high-wear
warning, each with its uncertainty; tyre rotations and replacements are found in the radius
ratio.

DRIVES are stream files (in drive order; an extra ``odometer`` column [m] lets each drive stand
for the distance to the next), one manifest (a ``.txt`` list of stream paths, or a CSV with a
``path`` column, relative to the manifest, and optionally ``vehicle``), or one drive-summary table
(CSV/Parquet with the columns of
:data:`tyrebayes.streams.wear_evidence.WEAR_EVIDENCE_COLUMNS`, ``vehicle``, ``drive_id`` and an
order column: ``drive_order``, ``start_time`` or ``odometer_start_km``; the lateral-work columns
are optional: without them the history has no lateral work).

The lateral friction work (thesis eq. 4.19b) needs the axles' cornering stiffness: ``--tyre-fit``
takes it from a saved tyre fit's lateral posterior; without one, stream files give it themselves
(the lateral fit of the first of them, up to five, whose fit is usable:
:func:`tyrebayes.inference.wear.cornering_stiffness_from_drives`); where neither gives one, or
with ``--type-prior-cornering``, the type prior is used. A fleet run's drive-summary table has
its lateral work put on each tyre set's c_y from its drives' lateral estimates
(:func:`tyrebayes.batch.with_drive_cornering`; a set without any, or
``--type-prior-cornering``, keeps the c_y the table holds). The output's
``lateral_work.cornering_stiffness_source`` says which, and ``lateral_work.note`` why.

Exit status: 0 on a converged fit; 2 on bad input (one line: a history of one drive, drives of
different vehicles, readings that increase, ...); 3 when the fit did not converge (the summary is
still printed and written, marked ``"converged": false``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .._errors import BadInputError
from ._common import (
    diagnostics_text,
    existing_file,
    exit_status,
    output_file,
    print_json,
    save_fit,
)

#: Order columns of a drive-summary table, in order of preference.
ORDER_COLUMNS = ("drive_order", "start_time", "odometer_start_km")
_TABLE_SUFFIXES = (".csv", ".parquet", ".pq")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fit-wear",
        help="abrasability gamma, tread depth and km to 3/1.6 mm from a car's drive history",
        description=(
            "Fit the tread-wear model to one car's drive history (stream files, a manifest or a "
            "drive-summary table), optionally with tread-depth readings. Exit status 3 when the "
            "fit did not converge."
        ),
    )
    parser.add_argument("drives", nargs="+", help="stream files, a manifest, or a summary table")
    parser.add_argument(
        "--vehicle", required=True, help="vehicle preset name (e.g. compact_fwd) or TOML path"
    )
    parser.add_argument(
        "--tread-depth",
        default=None,
        help="CSV of tread-depth readings: odometer_km, axle (front/rear), depth_mm",
    )
    parser.add_argument(
        "--tyre-type",
        default="summer",
        choices=("summer", "winter", "all_season"),
        help="tyre type for the high-wear warning's reference (ADAC convoy wear)",
    )
    parser.add_argument(
        "--tyre-fit",
        default=None,
        help="a saved tyre fit (fit-tyre --out) whose lateral posterior gives the axles' "
        "cornering stiffness for the lateral work (default: the lateral fit of the drives "
        "themselves)",
    )
    parser.add_argument(
        "--type-prior-cornering",
        action="store_true",
        help="take the lateral work's cornering stiffness from the tyre type's prior, not from "
        "a lateral fit of the drives",
    )
    parser.add_argument(
        "--baseline", action="store_true", help="no temperature sensitivity (kappa = 0)"
    )
    parser.add_argument(
        "--samples", type=int, default=500, help="NUTS warm-up and draws per chain (2 chains)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--out",
        help="write the fit (netCDF, read back with tyrebayes.load_fit; missing folders are "
        "created)",
    )
    parser.add_argument("--json", action="store_true", help="machine-readable output")
    parser.set_defaults(func=run)


def _read_table(path: Path):
    import pandas as pd

    try:
        if path.suffix.lower() == ".csv":
            return pd.read_csv(path)
        return pd.read_parquet(path)
    except (OSError, ValueError) as err:
        raise BadInputError(f"{path}: expected a CSV or Parquet table, got {err}") from None


def _vehicle_name(vehicle: str) -> str:
    return Path(vehicle).stem if vehicle.endswith(".toml") else vehicle


def _check_one_vehicle(values, vehicle: str) -> None:
    names = sorted({str(v) for v in values if str(v) not in ("", "nan")})
    if len(names) > 1:
        raise BadInputError(f"drive history: expected drives of one vehicle, got {names}")
    if names and names[0] != _vehicle_name(vehicle):
        raise BadInputError(
            f"drive history: expected drives of --vehicle {_vehicle_name(vehicle)}, "
            f"got drives of {names[0]}"
        )


def _summary_table(table, vehicle: str):
    from ..inference.wear.history import HISTORY_COLUMNS

    missing = [c for c in HISTORY_COLUMNS if c not in table]
    if missing:
        raise BadInputError(f"drive-summary table: expected columns {missing}, not found")
    if "vehicle" in table:
        _check_one_vehicle(table["vehicle"], vehicle)
    order = next((c for c in ORDER_COLUMNS if c in table), None)
    if order is None:
        raise BadInputError(
            f"drive-summary table: expected an order column, one of {ORDER_COLUMNS}"
        )
    return table.sort_values(order, kind="stable").reset_index(drop=True)


def _manifest_paths(path: Path, vehicle: str) -> list[Path]:
    if path.suffix.lower() == ".txt":
        lines = [ln.strip() for ln in path.read_text().splitlines()]
        entries = [ln for ln in lines if ln and not ln.startswith("#")]
    else:
        table = _read_table(path)
        if "vehicle" in table:
            _check_one_vehicle(table["vehicle"], vehicle)
        entries = [str(p) for p in table["path"]]
    return [p if p.is_absolute() else path.parent / p for p in map(Path, entries)]


def drive_table(drives: list[str], vehicle: str, cornering=None, fit_cornering: bool = False):
    """The evidence table of DRIVES (streams, a manifest or a summary table), in drive order,
    and a note on the cornering stiffness behind its lateral work ("" when nothing to say).

    ``cornering``: the axles' c_y for the lateral work of stream files (a summary table keeps
    its own; giving one with a table is bad input). ``fit_cornering``: without ``cornering``,
    take it from the stream files' own lateral fits (:func:`_drives_cornering`).
    """
    from .._domain import load_vehicle
    from ..streams.wear_evidence_table import wear_evidence_table

    paths = [existing_file(d) for d in drives]
    if len(paths) == 1:
        path = paths[0]
        if path.suffix.lower() == ".txt":
            paths = _manifest_paths(path, vehicle)
        elif path.suffix.lower() in _TABLE_SUFFIXES:
            table = _read_table(path)
            if "work_x_front_j" in table:
                if cornering is not None:
                    raise BadInputError(
                        "--tyre-fit: expected stream files (a drive-summary table's lateral work "
                        "was computed with its own cornering stiffness), got a summary table"
                    )
                table = _summary_table(table, vehicle)
                if not fit_cornering:
                    return table, ""
                from ..batch.lateral import with_drive_cornering

                return with_drive_cornering(table)
            if "path" in table:
                paths = _manifest_paths(path, vehicle)
    if len(paths) < 2:
        raise BadInputError(f"drive history: expected at least 2 drives, got {len(paths)}")
    paths = [existing_file(str(p)) for p in paths]
    try:
        car = load_vehicle(vehicle)
    except ValueError as err:
        raise BadInputError(str(err).splitlines()[0]) from None
    note = ""
    if cornering is None and fit_cornering:
        cornering, note = _drives_cornering(paths, car)
    return wear_evidence_table(paths, car, _vehicle_name(vehicle), cornering=cornering), note


def _drives_cornering(paths: list[Path], car):
    """(the drives' own c_y or None, a one-line note): the first usable lateral fit among the
    first drives (:func:`~tyrebayes.inference.wear.cornering_stiffness_from_drives`)."""
    from ..inference.wear.cornering import cornering_stiffness_from_drives
    from ..streams import read_stream, validate_stream

    frames = ((p.name, validate_stream(read_stream(p), car).data) for p in paths)
    found = cornering_stiffness_from_drives(frames, car)
    return found.stiffness, found.note


def _text(out: dict, diagnostics) -> str:
    def line(name: str, s: dict, fmt: str = ".4g") -> str:
        lo, hi = s["hdi_90"]
        return f"{name:22s} {s['mean']:{fmt}} ± {s['sd']:.2g}  (90% HDI {lo:{fmt}} … {hi:{fmt}})"

    lines = [
        f"{out['n_drives']} drives, {out['history_km']:.0f} km",
        line("gamma [mm^3/J]", out["gamma"]),
    ]
    if "kappa" in out:
        lines.append(line("kappa [1/K]", out["kappa"]))
    for axle in ("front", "rear"):
        lines.append(line(f"wear {axle} [mm/1000km]", out["wear_mm_per_1000km"][axle]))
        lines.append(line(f"depth {axle} now [mm]", out["depth_now_mm"][axle], ".3g"))
    lines.append(line("km to 3 mm", out["km_to_3mm"], ".0f"))
    lines.append(line("km to 1.6 mm", out["km_to_1_6mm"], ".0f"))
    for change in out["tyre_changes"]:
        lines.append(
            f"tyre change at drive {change['drive_index']} ({change['odometer_km']:.0f} km): "
            f"{change['change_type']} (p = {change['probability']:.2f})"
        )
    lines.append(out["high_wear"]["message"])
    return "\n".join([*lines, diagnostics_text(diagnostics)])


def run(args: argparse.Namespace) -> int:
    if not 50 <= args.samples <= 100000:
        raise BadInputError(f"--samples: expected 50 to 100000, got {args.samples}")
    if args.out is not None:
        output_file(args.out, suffixes=(".nc", ".netcdf"))
    import jax

    # radius ratios are ~1e-4 apart: the model's covariances need float64
    jax.config.update("jax_enable_x64", True)
    import json

    from .._io import to_jsonable
    from ..decisions import high_wear_warning
    from ..inference.wear.history import drive_history, tread_readings
    from ..inference.wear.history_fit import fit_wear_history
    from ..inference.wear.history_predict import wear_history_predictions

    if args.tyre_fit is not None and args.type_prior_cornering:
        raise BadInputError(
            "--type-prior-cornering: expected no --tyre-fit beside it (which c_y is meant?)"
        )
    cornering, note = None, ""
    if args.tyre_fit is not None:
        from ..inference.result import load_fit
        from ..inference.tyre.result import TyreFit
        from ..inference.wear.cornering import cornering_stiffness_from_tyre_fit

        tyre_fit = load_fit(args.tyre_fit, kind="tyre")
        cornering = cornering_stiffness_from_tyre_fit(tyre_fit)
        lateral = TyreFit.from_fit(tyre_fit).lateral
        if cornering is None and lateral is not None:
            note = f"{args.tyre_fit}: {lateral.unusable_reason()}: the type prior's c_y is used"
        elif cornering is None:
            note = f"{args.tyre_fit} has no lateral posterior: the type prior's c_y is used"
    table, table_note = drive_table(
        args.drives,
        args.vehicle,
        cornering,
        fit_cornering=args.tyre_fit is None and not args.type_prior_cornering,
    )
    note = note or table_note
    history = drive_history(table)
    readings = None
    if args.tread_depth is not None:
        readings = tread_readings(_read_table(existing_file(args.tread_depth)))
    fit = fit_wear_history(
        history,
        readings,
        extended=not args.baseline,
        num_warmup=args.samples,
        num_samples=args.samples,
        seed=args.seed,
        source=" ".join(args.drives),
    )
    prediction = wear_history_predictions(fit, history, readings, tyre_type=args.tyre_type)
    out = prediction.to_dict()
    out["high_wear"] = high_wear_warning(prediction.wear_over_reference).to_dict()
    if note:
        out["lateral_work"]["note"] = note
    out["vehicle"] = _vehicle_name(args.vehicle)
    out["converged"] = fit.converged
    out["diagnostics"] = fit.diagnostics.as_dict()
    fit.data.attrs["predictions"] = json.dumps(to_jsonable(out))
    if args.out is not None:
        out["out"] = save_fit(fit, args.out)
    if args.json:
        print_json(out)
    else:
        print(_text(out, fit.diagnostics))
    return exit_status(fit, "fit-wear")
