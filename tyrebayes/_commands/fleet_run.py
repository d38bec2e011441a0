"""``tyrebayes fleet-run MANIFEST --out DIR [--scheduler ADDR] [--workers N] [--method fast|nuts]``.

Runs the three stages of :mod:`tyrebayes.batch` on dask.distributed: with no ``--scheduler`` a
``LocalCluster`` of ``--workers`` single-threaded processes (default one per core) with a memory
limit each; with an address the existing cluster. Prints the run's summary (items done, skipped,
failed, time per stage; JSON with ``--json``). ``--out`` and its parent folders are created.

Exit status (:data:`EXIT_STATUS`):

* 0 — every drive, tyre set and the fleet model done (now, or unchanged since a run before);
* 4 — finished with failures: some items failed (listed with their one-line reasons, and in
  ``failures.csv``), the rest is written;
* 2 — nothing usable: no tyre set has a fit (every drive failed, say), and the last run's
  ``tyre_sets.parquet`` is left as it was; or a bad manifest or option (one line, nothing run);
* 130 / 143 — stopped by Ctrl-C / SIGTERM: the items in flight are not recorded as failed and run
  again on the rerun, no table is written, the cluster is closed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from .._errors import BadInputError
from ..internal.jax_cache import default_cache_dir
from ._common import EXIT_FAILURES, output_folder, print_json

if TYPE_CHECKING:
    from ..batch.run_result import FleetRunResult

# tyrebayes.inference.tyre.model.CURVE_MODELS (spelled out: importing it would start JAX).
MODEL_CHOICES = ("magic", "shaped", "brush", "linear")

#: Exit status by the run's outcome (:func:`tyrebayes.batch.run_result.run_outcome`).
EXIT_STATUS = {"ok": 0, "failures": EXIT_FAILURES, "nothing_usable": 2}


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fleet-run",
        help="many drive logs to per-tyre-set and fleet posteriors on dask.distributed",
        description=(
            "Process every drive of a manifest (CSV/Parquet: path, vehicle, tyre_set_id, "
            "optional tyre_type, surface, ambient_c, profile) or a glob of logs with --vehicle: "
            "per drive a windows table and summary row, per tyre set a joint fit, then the "
            "fleet model. Reruns skip unchanged items. Exit status 0: all done; 4: finished "
            "with failed items (listed); 2: nothing usable (no tyre set fitted) or bad input; "
            "130/143: interrupted (items in flight run again on the rerun)."
        ),
    )
    parser.add_argument("manifest", help="manifest (.csv, .parquet) or a quoted glob of logs")
    parser.add_argument("--out", required=True, help="output folder (created, with its parents)")
    parser.add_argument("--scheduler", help="address of a dask scheduler (default: a local one)")
    parser.add_argument("--workers", type=int, help="local workers (default: one per core)")
    parser.add_argument(
        "--memory-limit", default=None, help="per local worker (default 4GiB; dask syntax)"
    )
    parser.add_argument(
        "--memory-budget",
        type=float,
        default=1536.0,
        metavar="MB",
        help="peak a worker keeps each task under by dropping programs compiled for earlier "
        "tasks (default 1536)",
    )
    parser.add_argument("--method", choices=("fast", "nuts"), default="fast")
    parser.add_argument("--model", choices=MODEL_CHOICES, default=MODEL_CHOICES[0])
    parser.add_argument(
        "--load-sensitivity",
        action="store_true",
        help="fit the tyre sets with C_x following the driven axle's load (q's measured prior)",
    )
    parser.add_argument(
        "--no-lateral",
        action="store_true",
        help="skip the per-drive lateral fits (the tyre sets then carry no c_y, and the fleet "
        "model learns no ratio c_y / C_xr)",
    )
    parser.add_argument("--vehicle", help="vehicle of every log of a glob")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--pointwise",
        action="store_true",
        help="keep each tyre set's per-window log-likelihood and predictive draws in its fit "
        "file (default: left out; criticize recomputes them)",
    )
    parser.add_argument(
        "--jax-cache",
        help="JAX compilation cache shared by the workers (default $TYREBAYES_JAX_CACHE or "
        "~/.cache/tyrebayes/jax; '' for none)",
    )
    parser.add_argument("--json", action="store_true", help="machine-readable summary")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..batch import RunSettings, dask_client, fleet_run, read_manifest
    from ..batch.run_folder import prepare_out, sweep_run_temporaries

    if args.workers is not None and args.workers < 1:
        raise BadInputError(f"--workers: expected >= 1, got {args.workers}")
    if args.workers is not None and args.scheduler:
        raise BadInputError("--workers: expected only without --scheduler, got both")
    items = read_manifest(args.manifest, vehicle=args.vehicle)
    out = output_folder(args.out)
    if not args.memory_budget > 0:
        raise BadInputError(f"--memory-budget: expected > 0 MB, got {args.memory_budget}")
    settings = RunSettings(
        memory_budget_mb=args.memory_budget,
        method=args.method,
        model=args.model,
        load_sensitivity=args.load_sensitivity,
        seed=args.seed,
        pointwise=args.pointwise,
        lateral=not args.no_lateral,
        jax_cache=default_cache_dir() if args.jax_cache is None else args.jax_cache,
    )
    prepare_out(out)  # a file where a stage folder belongs: one line, before the cluster
    try:
        with dask_client(args.scheduler, args.workers, args.memory_limit) as client:
            result = fleet_run(items, out, client, settings)
    finally:
        if not args.scheduler:
            # The local workers are gone: what the ones killed in a write left is stale now.
            sweep_run_temporaries(out)
    status = EXIT_STATUS[result.outcome]
    if status == 2:
        _print_nothing_usable(result, out)
    if args.json:
        print_json(result.to_dict())
        return status
    _print_summary(result, out)
    return status


def _print_nothing_usable(result: FleetRunResult, out: Path) -> None:
    """The one line on stderr of a run in which no tyre set was fitted."""
    drives, sets = result.drives, result.tyre_sets
    print(
        f"tyrebayes fleet-run: nothing usable: no tyre set was fitted ({drives.failed} of "
        f"{drives.items} drives and {sets.failed} of {sets.items} tyre sets failed; "
        f"reasons in {out / 'failures.csv'})",
        file=sys.stderr,
    )


def _print_summary(result: FleetRunResult, out: Path) -> None:
    """The run's summary for a person: a line per stage, the failures, the time."""
    for name, s in (("drives", result.drives), ("tyre_sets", result.tyre_sets)):
        print(
            f"{name:9s} {s.items} items: {s.done} done, {s.skipped} skipped, "
            f"{s.failed} failed ({s.seconds:.1f} s in tasks)"
        )
    fleet = result.fleet
    print(f"fleet     {fleet.status}{' (skipped)' if fleet.skipped else ''} {fleet.reason}")
    for failure in result.failures:
        if failure.item != "fleet":  # its line is above
            print(f"failed {failure.item} {failure.item_id}: {failure.reason}")
    print(f"{result.wall_seconds:.1f} s on {result.workers} workers -> {out}")
