"""``tyrebayes criticize`` and ``tyrebayes criticize-stream``: find what the model does not know."""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from .._errors import BadInputError
from ._common import (
    _FIT_SIGNATURES,
    add_can_arguments,
    existing_file,
    fit_file,
    print_json,
    stream_file,
)


def register(subparsers) -> None:
    """Add the ``criticize`` and ``criticize-stream`` sub-commands."""
    p = subparsers.add_parser(
        "criticize",
        help="find what a fitted model (fit file) or a fleet table's 1/C_xr model lacks",
        description=(
            "Criticise a fitted model from its fit file (fleet fits need --table, the fleet table "
            "they were made from; per-tyre fits from fit-tyre --out need nothing else), or a fleet "
            "table's type-pooled regression of OUTCOME on 1/C_xr. Posterior predictive checks, "
            "then every candidate covariate is scanned against the residuals with a permutation "
            "test, Benjamini-Hochberg over candidates (false-discovery rate --alpha), and is a "
            "finding only if the extended model's PSIS-LOO ELPD gain is positive."
        ),
    )
    p.add_argument(
        "input", help="fit file (netCDF from fit-fleet or fit-tyre) or fleet table (CSV)"
    )
    p.add_argument("--table", default=None, help="fleet table a fleet fit was made from (CSV)")
    p.add_argument("--outcome", default=None, help="outcome column of a fleet table, e.g. mu")
    p.add_argument("--surface", default=None, help="surface to use when the table holds several")
    p.add_argument("--alpha", type=float, default=0.05, help="false-discovery rate of the rule")
    p.add_argument("--seed", type=int, default=0, help="seed of permutations and draws")
    p.add_argument("--permutations", type=int, default=999, help="permutations behind each p-value")
    p.add_argument(
        "--se-factor",
        type=float,
        default=0.0,
        help="a finding's ELPD gain must also exceed this many SE (default 0: positive)",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=_run_table)

    s = subparsers.add_parser(
        "criticize-stream",
        help="scan a sensor stream for effects the linear-slip model lacks",
        description=(
            "Criticise the linear-slip model rho_x = C_x (sigma_x - s0), pooled over the drive, "
            "against per-segment candidates (speed, IMU/grade proxies, cornering, radius "
            "mismatch, temperature, time); leave-one-segment-out PSIS-LOO."
        ),
    )
    s.add_argument(
        "stream",
        help="stream file (CSV or Parquet) in the DESIGN.md contract, or a CAN log with --profile",
    )
    s.add_argument("--vehicle", required=True, help="vehicle name (e.g. suv_rav4) or TOML path")
    add_can_arguments(s)
    s.add_argument("--window", type=float, default=None, help="segment length [s]")
    s.add_argument("--alpha", type=float, default=0.05, help="false-discovery rate of the rule")
    s.add_argument("--seed", type=int, default=0, help="seed of permutations and draws")
    s.add_argument(
        "--se-factor",
        type=float,
        default=0.0,
        help="a finding's ELPD gain must also exceed this many SE (default 0: positive)",
    )
    s.add_argument("--json", action="store_true", help="machine-readable output")
    s.set_defaults(func=_run_stream)


def _check_alpha(alpha: float, se_factor: float) -> None:
    if not 0.0 < alpha < 1.0:
        raise BadInputError(f"--alpha: expected a value in (0, 1), got {alpha}")
    if not se_factor >= 0.0:
        raise BadInputError(f"--se-factor: expected a value >= 0, got {se_factor}")


def _read_table(path_arg: str) -> pd.DataFrame:
    path = existing_file(path_arg)
    try:
        return pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise BadInputError(f"fleet table: expected a CSV file, got unreadable '{path}'") from err


def _is_fit_file(path: Path) -> bool:
    with path.open("rb") as fh:
        return fh.read(8).startswith(_FIT_SIGNATURES)


def _run_table(args: argparse.Namespace) -> int:
    from ..criticism import criticize_fleet_fit, criticize_table, criticize_tyre_fit
    from ..inference.result import load_fit

    _check_alpha(args.alpha, args.se_factor)
    if args.permutations < 99:
        raise BadInputError(f"--permutations: expected at least 99, got {args.permutations}")
    path = existing_file(args.input)
    common = {
        "alpha": args.alpha,
        "seed": args.seed,
        "se_factor": args.se_factor,
        "n_permutations": args.permutations,
    }
    if _is_fit_file(path):
        fit = load_fit(fit_file(args.input))
        if fit.kind == "fleet":
            if args.table is None:
                raise BadInputError(
                    "fleet fit: expected --table TABLE, the fleet table it was made from"
                )
            result = criticize_fleet_fit(fit, _read_table(args.table), **common)
            title = f"{path.name}: hierarchical fleet fit of {fit.data.attrs['outcome']}"
        elif fit.kind == "tyre":
            result = criticize_tyre_fit(fit, **common)
            title = f"{path.name}: per-tyre fit (slip residuals)"
        else:
            raise BadInputError(
                f"fit file {path}: expected a fleet or tyre fit, got a {fit.kind} fit"
            )
    else:
        if args.table is not None:
            raise BadInputError(
                f"--table: expected only with a fleet fit file, got the table '{path.name}'"
            )
        if args.outcome is None:
            raise BadInputError("fleet table: expected --outcome COLUMN (e.g. --outcome mu)")
        result = criticize_table(
            _read_table(args.input), args.outcome, surface=args.surface, **common
        )
        title = f"{path.name}: {args.outcome} ~ 1/C_xr (type-pooled)"
    _emit(result, args.json, title)
    return 0


def _run_stream(args: argparse.Namespace) -> int:
    from ..criticism import criticize_stream

    _check_alpha(args.alpha, args.se_factor)
    if args.window is not None and not args.window > 0:
        raise BadInputError(f"--window: expected a positive length in s, got {args.window}")
    with stream_file(args, args.vehicle) as path:
        result = criticize_stream(
            path,
            args.vehicle,
            window_s=args.window,
            alpha=args.alpha,
            seed=args.seed,
            se_factor=args.se_factor,
        )
    name = Path(args.stream).name
    _emit(result, args.json, f"{name}: rho_x = C_x (sigma_x - s0)")
    return 0


def _emit(result, as_json: bool, title: str) -> None:
    if as_json:
        print_json(result.to_json())
        return
    b = result.baseline
    print(f"criticism of {title}")
    print(
        f"baseline: ELPD {b.elpd:.2f} (SE {b.se:.2f}) over {b.pointwise.shape[0]} units, "
        f"Pareto k max {b.k_max:.2f}, {b.n_k_high} unit(s) > 0.7"
    )
    print("posterior predictive checks (p-value outside [0.025, 0.975] = misfit):")
    for name, v in result.ppc.items():
        flag = "  <-- misfit" if not 0.025 <= v["p_value"] <= 0.975 else ""
        print(f"  {name:<36} T(y) = {v['observed']:+.4g}  p = {v['p_value']:.3f}{flag}")
    print(
        f"candidates (p: permutation test, {result.n_permutations} permutations; q: "
        "Benjamini-Hochberg; * = found):"
    )
    print(
        f"  {'covariate':<24} {'p':>7} {'q':>7} {'ELPD gain':>10} {'SE':>7} {'k_max':>6}  "
        "effect mean [90% HDI]"
    )
    for c in result.candidates:
        e = c.effect
        lvl = f" ({c.level})" if c.level else ""
        mark = " *" if c.found else ""
        print(
            f"  {c.covariate:<24} {c.p_value:>7.3g} {c.q_value:>7.3g} {c.elpd_gain:>10.2f} "
            f"{c.se:>7.2f} {c.pareto_k_max:>6.2f}  {e['mean']:+.4g} [{e['hdi_90'][0]:+.4g}, "
            f"{e['hdi_90'][1]:+.4g}]{lvl}{mark}"
        )
    found = ", ".join(result.found) if result.found else "nothing"
    print(f"found (BH q <= {result.alpha:g} and ELPD gain > 0, confirmed in order): {found}")
    for c in result.candidates:
        if c.q_value <= result.alpha and not c.found:
            print(f"not a finding: {c.covariate}: {c.reason}")
    for note in result.notes:
        print(f"note: {note}")
