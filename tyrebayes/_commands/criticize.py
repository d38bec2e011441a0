"""``tyrebayes criticize`` and ``tyrebayes criticize-stream``: find what the model does not know."""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from .._errors import BadInputError
from ._common import add_can_arguments, existing_file, print_json, stream_file


def register(subparsers) -> None:
    """Add the ``criticize`` and ``criticize-stream`` sub-commands."""
    p = subparsers.add_parser(
        "criticize",
        help="scan a fleet table for effects the 1/C_xr model lacks (PSIS-LOO confirmed)",
        description=(
            "Criticise the type-pooled regression of OUTCOME on 1/C_xr: every other column of the "
            "fleet table is a candidate covariate; candidates are scanned (likelihood-ratio test, "
            "Holm over candidates) and confirmed by an extended model whose PSIS-LOO ELPD gain "
            "over the baseline exceeds 2 SE."
        ),
    )
    p.add_argument("table", help="fleet table (CSV): tyre_id, tyre_type, c_xr, outcome, ...")
    p.add_argument("--outcome", required=True, help="outcome column, e.g. mu")
    p.add_argument("--surface", default=None, help="surface to use when the table holds several")
    p.add_argument("--alpha", type=float, default=0.05, help="family-wise error of the scan")
    p.add_argument("--seed", type=int, default=0, help="seed of the posterior draws")
    p.add_argument(
        "--se-factor", type=float, default=2.0, help="a finding must gain more than this many SE"
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
    s.add_argument("--alpha", type=float, default=0.05, help="family-wise error of the scan")
    s.add_argument("--seed", type=int, default=0, help="seed of the posterior draws")
    s.add_argument(
        "--se-factor", type=float, default=2.0, help="a finding must gain more than this many SE"
    )
    s.add_argument("--json", action="store_true", help="machine-readable output")
    s.set_defaults(func=_run_stream)


def _check_alpha(alpha: float, se_factor: float) -> None:
    if not 0.0 < alpha < 1.0:
        raise BadInputError(f"--alpha: expected a value in (0, 1), got {alpha}")
    if not se_factor >= 0.0:
        raise BadInputError(f"--se-factor: expected a value >= 0, got {se_factor}")


def _run_table(args: argparse.Namespace) -> int:
    from ..criticism import criticize_table

    _check_alpha(args.alpha, args.se_factor)
    path = existing_file(args.table)
    try:
        table = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise BadInputError(f"fleet table: expected a CSV file, got unreadable '{path}'") from err
    result = criticize_table(
        table,
        args.outcome,
        surface=args.surface,
        alpha=args.alpha,
        seed=args.seed,
        se_factor=args.se_factor,
    )
    _emit(result, args.json, f"{path.name}: {args.outcome}", args.se_factor)
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
    _emit(result, args.json, f"{name}: rho_x = C_x (sigma_x - s0)", args.se_factor)
    return 0


def _emit(result, as_json: bool, title: str, se_factor: float) -> None:
    if as_json:
        print_json(result.to_json())
        return
    b = result.baseline
    print(f"criticism of {title}")
    print(
        f"baseline: ELPD {b.elpd:.2f} (SE {b.se:.2f}) over {b.pointwise.shape[0]} units, "
        f"Pareto k max {b.k_max:.2f}, {b.n_k_high} unit(s) > 0.7 (exact LOO used)"
    )
    print("posterior predictive checks (p-value outside [0.025, 0.975] = misfit):")
    for name, v in result.ppc.items():
        flag = "  <-- misfit" if not 0.025 <= v["p_value"] <= 0.975 else ""
        print(f"  {name:<36} T(y) = {v['observed']:+.4g}  p = {v['p_value']:.3f}{flag}")
    print(
        "candidates (sorted by evidence; p: residual scan, p_holm: Holm-adjusted, p_loglik: "
        "pointwise log-likelihood scan; * = found):"
    )
    print(
        f"  {'covariate':<24} {'p':>9} {'p_holm':>9} {'misfit%':>8} {'p_loglik':>9} "
        f"{'ELPD gain':>10} {'SE':>7} {'k_max':>6}  effect mean [90% HDI]"
    )
    for c in result.candidates:
        e = c.effect
        lvl = f" ({c.level})" if c.level else ""
        mark = " *" if c.found else ""
        print(
            f"  {c.covariate:<24} {c.p_value:>9.2g} {c.p_holm:>9.2g} "
            f"{100 * c.misfit_explained:>7.1f}% {c.p_loglik:>9.2g} "
            f"{c.elpd_gain:>10.2f} {c.se:>7.2f} "
            f"{c.pareto_k_max:>6.2f}  {e['mean']:+.4g} [{e['hdi_90'][0]:+.4g}, "
            f"{e['hdi_90'][1]:+.4g}]{lvl}{mark}"
        )
    found = ", ".join(result.found) if result.found else "nothing (no candidate passes)"
    print(f"found (Holm p <= alpha and ELPD gain > {se_factor:g} SE): {found}")
    for note in result.notes:
        print(f"note: {note}")
