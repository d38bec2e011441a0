"""``tyrebayes vmax``: critical ISO 3888-2 lane-change speed of a vehicle on given tyres.

``tyrebayes vmax --vehicle compact_fwd --c-x 40 --mu 1.0 [--type all_season] [--c-y CY] [--json]``
C_y defaults to k_type · C_x (type-level relation in :mod:`tyrebayes.inference.vmax`); μ_y =
0.95 μ_x.
"""

from __future__ import annotations

import argparse

from .._domain import TYRE_TYPES
from .._errors import BadInputError
from ._common import print_json


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "vmax",
        help="critical speed of the ISO 3888-2 double lane change (driver-free simulation)",
        description="Single-track model with lateral brush tyres and a preview driver; bisection.",
    )
    p.add_argument("--vehicle", default="compact_fwd", help="vehicle name or JSON path")
    p.add_argument("--c-x", type=float, required=True, help="longitudinal stiffness C_x [-]")
    p.add_argument("--mu", type=float, required=True, help="longitudinal peak friction mu_x [-]")
    p.add_argument("--type", default="all_season", choices=TYRE_TYPES)
    p.add_argument("--c-y", type=float, default=None, help="override cornering stiffness [1/rad]")
    p.add_argument("--exit-lane", default="thesis", choices=["thesis", "standard"])
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not (args.c_x > 0 and 0 < args.mu < 3):
        raise BadInputError(f"expected --c-x > 0 and 0 < --mu < 3, got {args.c_x}, {args.mu}")
    from .._domain import load_vehicle
    from ..inference.vmax import K_TYPE, MU_Y_RATIO
    from ..physics.lanechange import Tyres, critical_speed, iso3888_2_course

    try:
        vehicle = load_vehicle(args.vehicle)
    except (FileNotFoundError, ValueError, KeyError) as exc:
        raise BadInputError(
            f"expected a known vehicle name or JSON file, got {args.vehicle!r}"
        ) from exc
    c_y = args.c_y if args.c_y is not None else K_TYPE[args.type] * args.c_x
    mu_y = MU_Y_RATIO * args.mu
    course = iso3888_2_course(vehicle.width_m, exit_lane=args.exit_lane)
    cs = critical_speed(vehicle, Tyres(c_y, mu_y), course, tol_mps=0.05)
    out = {
        "vehicle": args.vehicle,
        "c_y_per_rad": c_y,
        "mu_y": mu_y,
        "v_max_kmh": float(cs.v_max_mps) * 3.6,
        "v_fail_kmh": float(cs.v_fail_mps) * 3.6,
        "bracketed": bool(cs.bracketed),
    }
    if args.json:
        print_json(out)
    else:
        flag = "" if out["bracketed"] else "  (NOT bracketed: search range 29-162 km/h)"
        print(f"V_max {out['v_max_kmh']:.1f} km/h (C_y {c_y:.1f}/rad, mu_y {mu_y:.2f}){flag}")
    return 0
