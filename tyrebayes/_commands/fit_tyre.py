"""``tyrebayes fit-tyre STREAM --vehicle VEHICLE [--method nuts|fast] [--out FIT.nc] [--json]``.

Fits the per-tyre model (:mod:`tyrebayes.inference.tyre.model`) to one stream and prints the
posterior of C_x, C_xr, μ_max and the slip offset.

Exit status: 0 on a converged fit; 2 on bad input (one line on stderr); 3 when the fit did not
converge (R-hat, ESS, divergences, or the optimiser failed) — the summary is still printed and
written, marked ``"converged": false``, so that it is never mistaken for a good one.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from typing import Any

from .._domain import SURFACES
from .._errors import BadInputError
from ..internal.jax_cache import enable_compilation_cache
from ._common import (
    add_can_arguments,
    check_ambient,
    diagnostics_text,
    exit_status,
    output_file,
    print_json,
    save_fit,
    stream_file,
)

# tyrebayes.inference.tyre.model.CURVE_MODELS, default first; spelled out here because importing
# the model would start JAX before run() gives it one device per core (a test checks they agree).
MODEL_CHOICES = ("magic", "shaped", "brush", "linear")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "fit-tyre",
        help="posterior of C_x, C_xr and mu_max of one tyre set from a stream",
        description=(
            "Fit the per-tyre errors-in-variables tyre-curve model (Magic Formula by default) "
            "to a stream file and print the posterior of C_x, C_xr (20 °C), mu_max and the slip "
            "offset. Exit status 3 when the fit did not converge."
        ),
    )
    parser.add_argument(
        "stream", help="stream file (.csv, .parquet, .mf4), or a CAN log with --profile"
    )
    parser.add_argument(
        "--vehicle", required=True, help="vehicle preset name (e.g. suv_rav4) or TOML path"
    )
    parser.add_argument(
        "--method",
        choices=("nuts", "fast"),
        default="nuts",
        help="nuts: 4 chains x 1000 draws (default); fast: MAP + Laplace approximation",
    )
    parser.add_argument(
        "--surface",
        choices=SURFACES,
        default="dry",
        help="road surface (sets the mu_max prior; default dry)",
    )
    parser.add_argument(
        "--temperature",
        type=float,
        default=None,
        help="a fixed tyre temperature [°C] (default: estimated along the drive from speed "
        "and loads with the thermal model, starting at the ambient)",
    )
    parser.add_argument(
        "--ambient",
        type=float,
        default=None,
        help="ambient temperature [°C] (default: mean ambient_temperature column, else 20)",
    )
    parser.add_argument(
        "--model",
        choices=MODEL_CHOICES,
        default=MODEL_CHOICES[0],
        help=(
            "mean model (default magic: the Magic Formula with its shape and curvature drawn "
            "from the measured tyres; shaped: the brush with a fitted exponent; brush; linear)"
        ),
    )
    parser.add_argument(
        "--load-sensitivity",
        action="store_true",
        help="let C_x follow the driven axle's load (q with the measured tyres' prior; "
        "README: the load sensitivity of the slip stiffness)",
    )
    add_can_arguments(parser)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--out",
        help="write the fit (netCDF, read back with tyrebayes.load_fit; missing folders are "
        "created)",
    )
    parser.add_argument("--json", action="store_true", help="machine-readable output")
    parser.set_defaults(func=run)


def _validated(path, vehicle_name: str):
    """The validated stream and its vehicle: its flags (low rate, long gaps, dropped samples)
    qualify the answer, and it is what both fits read (validated once)."""
    from .._domain import load_vehicle
    from ..streams import read_stream, validate_stream

    try:
        vehicle = load_vehicle(vehicle_name)
    except ValueError as err:
        raise BadInputError(str(err).splitlines()[0]) from None
    return validate_stream(read_stream(path), vehicle), vehicle


def _cornering(validated, vehicle):
    """The drive's cornering observations and "", or None and the one-line reason there are none.

    Taken before the longitudinal fit, so that the full-rate frame need not be held through it.
    """
    from ..inference.lateral import NoCornering, cornering_observations

    try:
        return cornering_observations(validated.data, vehicle), ""
    except NoCornering as err:
        return None, str(err)


def _lateral(cornering, surface: str, seed: int, stream: str):
    """The drive's lateral fit and "", or None and the one-line reason there is none."""
    from ..inference.lateral import fit_lateral

    obs, reason = cornering
    if obs is None:
        return None, reason
    # MAP + Laplace with either --method: it is the lateral path the benchmarks validate
    # (benchmarks/lateral_external.py), and takes seconds where NUTS takes minutes.
    lateral = fit_lateral(
        obs,
        "laplace",
        surface=surface,
        seed=seed,
        inputs=(stream,),
    )
    if not lateral.identified:
        return None, (
            "lateral: not identified: the drive's cornering did not narrow the understeer "
            "gradient to half its prior's spread (kinematic or too gentle turning)"
        )
    return lateral, ""


def _text(summary: dict[str, Any], diagnostics) -> str:
    def line(name: str, key: str) -> str:
        s = summary[key]
        lo, hi = s["hdi_90"]
        return f"{name:12s} {s['mean']:.4g} ± {s['sd']:.2g}  (90% HDI {lo:.4g} … {hi:.4g})"

    lines = [
        line("C_x", "c_x"),
        line("C_xr (20°C)", "c_xr"),
        line("mu_max", "mu_max")
        + ("" if summary["mu_max_observed"] else "  [not observed: prior only]"),
        line("slip offset", "slip_offset"),
        line("force gain", "force_gain"),
        *([line("load sens. q", "load_sensitivity")] if "load_sensitivity" in summary else []),
        *_lateral_text(summary),
        f"{summary['n_samples_used']} windows ({summary['n_abs_windows']} ABS), "
        f"model {summary['model']}",
    ]
    flags = [f"stream flag: {flag}" for flag in summary["stream_flags"]]
    return "\n".join([*lines, diagnostics_text(diagnostics), *flags])


def _lateral_text(summary: dict[str, Any]) -> list[str]:
    lateral = summary["lateral"]
    if lateral is None:
        return [summary["lateral_reason"]]

    def line(name: str, s: dict) -> str:
        lo, hi = s["hdi_90"]
        return f"{name:12s} {s['mean']:.4g} ± {s['sd']:.2g}  (90% HDI {lo:.4g} … {hi:.4g})"

    lines = [
        line("c_y front", lateral["c_y_front"]),
        line("c_y rear", lateral["c_y_rear"]),
        line("understeer K", lateral["understeer_gradient"]),
    ]
    if lateral["steering_ratio"] is not None:
        lines.append(line("steer ratio", lateral["steering_ratio"]))
    lines.append(
        line("mu_y", lateral["mu_y"])
        if lateral["mu_y"] is not None
        else "mu_y         not observed"
    )
    if not (lateral["converged"] and lateral["adequate"]):
        lines.append(
            "lateral fit: "
            + ("not converged" if not lateral["converged"] else "")
            + ("; ".join(lateral["adequacy_reasons"]) if not lateral["adequate"] else "")
        )
    return lines


def run(args: argparse.Namespace) -> int:
    if args.out is not None:
        # Before JAX starts and the fit runs: a bad --out must not cost a fit.
        output_file(args.out, suffixes=(".nc", ".netcdf"))
    check_ambient(args.ambient)
    import numpyro

    if args.method == "nuts":
        # One JAX device per core before JAX starts: NUTS then runs its chains side by side.
        # Only then: each device's runtime costs the fast path memory it does not use.
        numpyro.set_host_device_count(max(1, min(4, os.cpu_count() or 1)))
    import jax

    # The slip signal is ~1e-3 and its noise ~1e-4: the MAP search and the Hessian need float64.
    jax.config.update("jax_enable_x64", True)
    enable_compilation_cache()
    from ..batch.worker_memory import drop_compiled_programs
    from ..inference.result import provenance
    from ..inference.tyre.data import observations_from_stream
    from ..inference.tyre.fit import fit_tyre
    from ..inference.tyre.model import TyrePriors

    with stream_file(args, args.vehicle) as path:
        validated, vehicle = _validated(path, args.vehicle)
        stream_flags = list(validated.flags)
        cornering = _cornering(validated, vehicle)
        obs = observations_from_stream(
            validated,
            vehicle,
            surface=args.surface,
            temperature_c=args.temperature,
            ambient_c=args.ambient,
        )
        del validated
    priors = TyrePriors().with_load_sensitivity() if args.load_sensitivity else None
    fit = fit_tyre(obs, priors=priors, method=args.method, model=args.model, seed=args.seed)
    # The longitudinal programs are not run again in this process: dropping them before the
    # lateral fit compiles its own keeps the command's peak at the larger of the two fits.
    drop_compiled_programs()
    lateral, lateral_reason = _lateral(cornering, args.surface, args.seed, args.stream)
    fit = dataclasses.replace(
        fit,
        lateral=lateral,
        lateral_reason=lateral_reason,
        provenance=provenance(
            args.method,
            args.model,
            (args.stream,),
            vehicle=str(args.vehicle),
            surface=args.surface,
            seed=args.seed,
            load_sensitivity=bool(args.load_sensitivity),
            stream_flags=" | ".join(stream_flags),
        ),
    )
    summary = fit.summary()
    summary["n_abs_windows"] = obs.n_limit
    summary["vehicle"] = args.vehicle
    summary["surface"] = args.surface
    summary["stream_flags"] = stream_flags
    if args.out is not None:
        summary["out"] = save_fit(fit, args.out)
    if args.json:
        print_json(summary)
    else:
        print(_text(summary, fit.diagnostics))
    return exit_status(fit, "fit-tyre")
