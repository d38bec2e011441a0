"""``tyrebayes vmax``: critical ISO 3888-2 lane-change speed of a vehicle on given tyres.

``tyrebayes vmax FIT.nc [--vehicle V] [--type T] [--draws N] [--json]``: the predictive V_max of a
per-tyre fit (``fit-tyre --out``). Where the fit carries a lateral posterior, the measured c_y
front and rear and μ_y (or μ_max, or the lateral posterior's μ_y, where μ_y was not observed)
enter the simulation, and ``lateral_source`` is ``"measured"``; otherwise C_y = k_type · C_xr
and μ_y = 0.95 μ_type (``"type_prior"``), or, with ``--fleet FLEET.nc`` (a fleet fit that learnt
the per-type ratio c_y / C_xr from sets with cornering), C_y = k · C_xr with k from the fleet's
posterior predictive for ``--type`` (``"fleet_type_ratio"``). ``mu_y_source`` says where μ_y came
from. The vehicle defaults to the one the fit was made with.

``tyrebayes vmax --vehicle compact_fwd --c-x 40 --mu 1.0 [--type all_season] [--c-y CY] [--json]``:
one V_max at given values; C_y defaults to k_type · C_x (type-level relation in
:mod:`tyrebayes.inference.vmax`); μ_y = 0.95 μ_x.
"""

from __future__ import annotations

import argparse
import json

from .._domain import TYRE_TYPES
from .._errors import BadInputError
from ._common import fit_file, print_json

DEFAULT_VEHICLE = "compact_fwd"


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "vmax",
        help="critical speed of the ISO 3888-2 double lane change (driver-free simulation)",
        description="Single-track model with lateral brush tyres and a preview driver; bisection. "
        "Give a per-tyre fit (FIT.nc from fit-tyre --out) for a predictive V_max, or --c-x and "
        "--mu for one value.",
    )
    p.add_argument(
        "fit", nargs="?", default=None, metavar="FIT", help="per-tyre fit (netCDF, fit-tyre --out)"
    )
    p.add_argument(
        "--vehicle",
        default=None,
        help=f"vehicle name or TOML path (default: the fit's vehicle, else {DEFAULT_VEHICLE})",
    )
    p.add_argument("--c-x", type=float, default=None, help="longitudinal stiffness C_x [-]")
    p.add_argument("--mu", type=float, default=None, help="longitudinal peak friction mu_x [-]")
    p.add_argument("--type", default="all_season", choices=TYRE_TYPES)
    p.add_argument("--c-y", type=float, default=None, help="override cornering stiffness [1/rad]")
    p.add_argument("--exit-lane", default="thesis", choices=["thesis", "standard"])
    p.add_argument(
        "--fleet",
        default=None,
        metavar="FLEET",
        help="fleet fit (fit-fleet --out, or a fleet run's fleet/fleet.nc) whose per-type ratio "
        "c_y / C_xr replaces k_type for a FIT without a lateral posterior",
    )
    p.add_argument("--draws", type=int, default=400, help="posterior draws for FIT (default 400)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run)


def _vehicle(name: str):
    from .._domain import load_vehicle

    try:
        return load_vehicle(name)
    except (FileNotFoundError, ValueError, KeyError) as exc:
        raise BadInputError(f"expected a known vehicle name or TOML file, got {name!r}") from exc


def run(args: argparse.Namespace) -> int:
    if args.fit is not None:
        return _run_fit(args)
    if args.fleet is not None:
        raise BadInputError("--fleet: expected a per-tyre fit FIT beside it, got values only")
    if args.c_x is None or args.mu is None:
        raise BadInputError("expected a fit file (FIT.nc) or both --c-x and --mu, got neither")
    if not (args.c_x > 0 and 0 < args.mu < 3):
        raise BadInputError(f"expected --c-x > 0 and 0 < --mu < 3, got {args.c_x}, {args.mu}")
    from ..inference.vmax import K_TYPE, MU_Y_RATIO
    from ..physics.lanechange import Tyres, critical_speed, iso3888_2_course

    vehicle_name = args.vehicle or DEFAULT_VEHICLE
    vehicle = _vehicle(vehicle_name)
    c_y = args.c_y if args.c_y is not None else K_TYPE[args.type] * args.c_x
    mu_y = MU_Y_RATIO * args.mu
    course = iso3888_2_course(vehicle.width_m, exit_lane=args.exit_lane)
    cs = critical_speed(vehicle, Tyres(c_y, mu_y), course, tol_mps=0.05)
    out = {
        "vehicle": vehicle_name,
        "c_y_per_rad": c_y,
        "mu_y": mu_y,
        "v_max_kmh": float(cs.v_max_mps) * 3.6,
        "v_fail_kmh": float(cs.v_fail_mps) * 3.6,
        "bracketed": bool(cs.bracketed),
        "below_range": bool(cs.below_range),
        "above_range": bool(cs.above_range),
    }
    if args.json:
        print_json(out)
    else:
        flag = ""
        if out["below_range"]:
            flag = "  (below the search range: the course is failed at its lowest speed)"
        elif out["above_range"]:
            flag = "  (above the search range: the course is passed at its highest speed)"
        print(f"V_max {out['v_max_kmh']:.1f} km/h (C_y {c_y:.1f}/rad, mu_y {mu_y:.2f}){flag}")
    return 0


def _run_fit(args: argparse.Namespace) -> int:
    values = (("--c-x", args.c_x), ("--mu", args.mu), ("--c-y", args.c_y))
    given = [flag for flag, value in values if value is not None]
    if given:
        raise BadInputError(f"expected a fit file or values, got both FIT and {', '.join(given)}")
    if not 1 <= args.draws <= 100_000:
        raise BadInputError(f"expected 1 <= --draws <= 100000, got {args.draws}")
    import jax

    jax.config.update("jax_enable_x64", True)
    from ..inference.result import load_fit
    from ..inference.tyre.result import TyreFit
    from ..inference.vmax import fit_vmax_inputs, predict_vmax
    from ..physics.lanechange import iso3888_2_course

    fit = load_fit(fit_file(args.fit, "a per-tyre fit (netCDF from fit-tyre --out)"))
    if fit.kind != "tyre":
        raise BadInputError(f"fit {args.fit}: expected a tyre fit (fit-tyre), got a {fit.kind} fit")
    tyre = TyreFit.from_fit(fit)
    vehicle_name = args.vehicle or _fit_vehicle(tyre) or DEFAULT_VEHICLE
    try:
        vehicle = _vehicle(vehicle_name)
    except BadInputError:
        if args.vehicle:
            raise
        raise BadInputError(
            f"expected the fit's vehicle {vehicle_name!r} to load (a name or a TOML path from "
            "where fit-tyre ran); give --vehicle"
        ) from None
    fleet = None
    if args.fleet is not None:
        fleet = load_fit(fit_file(args.fleet, "a fleet fit (netCDF from fit-fleet --out)"))
        if fleet.kind != "fleet":
            raise BadInputError(
                f"--fleet {args.fleet}: expected a fleet fit (fit-fleet), got a {fleet.kind} fit"
            )
    inputs = fit_vmax_inputs(
        tyre, jax.random.PRNGKey(args.seed), args.draws, args.type, fleet=fleet
    )
    course = iso3888_2_course(vehicle.width_m, exit_lane=args.exit_lane)
    pred = predict_vmax(vehicle, inputs, course=course, vehicle_name=vehicle_name)
    out = {"fit": str(args.fit), **pred.to_dict()}
    if inputs.lateral_source in ("type_prior", "fleet_type_ratio"):
        out["tyre_type"] = args.type
    if args.json:
        print_json(out)
    else:
        print(_text(out))
    return 0


def _fit_vehicle(tyre) -> str | None:
    """The vehicle the fit was made with (fit-tyre records it in the provenance), if any."""
    if tyre.provenance is None:
        return None
    vehicle = json.loads(tyre.provenance.settings).get("vehicle")
    return str(vehicle) if vehicle else None


def _text(out: dict) -> str:
    def line(name: str, s: dict, digits: int = 4) -> str:
        lo, hi = s["hdi_90"]
        return f"{name:10s} {s['mean']:.{digits}g} ± {s['sd']:.2g}  (90% HDI {lo:.4g} … {hi:.4g})"

    cornering = {
        "measured": "measured (the fit's lateral posterior)",
        "type_prior": f"type relation C_y = k_type C_xr ({out.get('tyre_type', '')})",
    }[out["lateral_source"]]
    lines = [
        line("V_max", out["v_max_kmh"]) + " km/h",
        f"cornering  {cornering}",
        line("c_y front", out["c_y_front"]),
        line("c_y rear", out["c_y_rear"]),
        line("mu_y", out["mu_y"]) + f"  [{out['mu_y_source']}; {out['surface']}]",
    ]
    if out["note"]:
        lines.append(f"note: {out['note']}")
    low, high = out["search_range_kmh"]
    if out["below_range"]:
        lines.append(
            f"{out['below_range']} draw(s) fail the course at {low:.0f} km/h, the search's lowest "
            f"speed: counted at {low:.1f} (V_max at most that)"
        )
    if out["above_range"]:
        lines.append(
            f"{out['above_range']} draw(s) pass at {high:.0f} km/h, the search's highest speed: "
            f"counted at {high:.0f} (V_max at least that)"
        )
    if out["undefined"]:
        lines.append(f"{out['undefined']} draw(s) fail low and pass high: no V_max, left out")
    return "\n".join(lines)
