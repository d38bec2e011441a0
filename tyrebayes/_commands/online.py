"""``tyrebayes online STREAM --vehicle VEHICLE [--json] [--figure PNG]``: the in-car estimator.

Runs the online estimator (:mod:`tyrebayes.inference.online`) over one stream step by step, as a
car would, and prints the trajectory of C_x: time, mean, 90 % interval and the "enough
evidence" flag (a value without enough evidence is withheld, with the reason), and the change
alarms. Beside it the lateral estimator (:mod:`tyrebayes.inference.online.lateral`) updates
c_y front and rear and the understeer gradient every 30 s of cornering; the output ends with its
``"lateral"`` object (null, with ``"lateral_reason"``, until the understeer gradient is
identified; c_y front and rear null, with the object's ``"reason"``, until the data tell front
from rear). ``--figure`` also draws the trajectory against the batch posterior of the whole stream
(``fit-tyre --method fast``).

Exit status: 0; 2 on bad input (one line on stderr).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from .._domain import SURFACES
from .._errors import BadInputError
from ._common import add_can_arguments, check_ambient, output_file, print_json, stream_file
from .fit_tyre import MODEL_CHOICES

# Said in every output: what the estimator read that a car would not have had yet.
LOOKAHEAD_NOTE = (
    "force-density scores (E[true force | measured force]) are estimated over the whole stream; "
    "slips and parameters are used only as they arrive; the cornering signals of the lateral "
    "estimate are low-passed zero-phase over the whole stream"
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "online",
        help="the tyre posterior updated online, step by step, with change alarms",
        description=(
            "Run the in-car estimator over a stream: the per-tyre posterior of C_x updated every "
            "30 s of driving (or packed up to --max-step-s), with its 90 %% interval, an "
            "'enough evidence' flag (values withheld until then) and alarms when C_x changes "
            "abruptly (tyre swap, puncture)."
        ),
    )
    parser.add_argument(
        "stream", help="stream file (.csv, .parquet, .mf4), or a CAN log with --profile"
    )
    parser.add_argument(
        "--vehicle", required=True, help="vehicle preset name (e.g. suv_rav4) or TOML path"
    )
    parser.add_argument("--surface", choices=SURFACES, default="dry", help="road surface")
    parser.add_argument("--temperature", type=float, default=None, help="fixed tyre temperature")
    parser.add_argument("--ambient", type=float, default=None, help="ambient temperature [°C]")
    parser.add_argument(
        "--model", choices=MODEL_CHOICES, default=MODEL_CHOICES[0], help="tyre-curve model"
    )
    parser.add_argument(
        "--figure", help="write a PNG of the trajectory against the batch posterior (fast fit)"
    )
    parser.add_argument(
        "--max-step-s",
        type=float,
        default=None,
        metavar="S",
        help=(
            "pack sparse driving into steps of up to S seconds (a multiple of 5, ≥ 30, e.g. "
            "60): fewer updates for a replay of logs, later alarms; default 30 s steps on the "
            "clock"
        ),
    )
    parser.add_argument(
        "--load-sensitivity",
        action="store_true",
        help="let C_x follow the driven axle's load (q with the measured tyres' prior)",
    )
    add_can_arguments(parser)
    parser.add_argument("--json", action="store_true", help="machine-readable output")
    parser.set_defaults(func=run)


def _value_text(value: dict | None, reason: str | None) -> str:
    if value is None:
        return f"—  ({reason})"
    lo, hi = value["hdi_90"]
    return f"{value['mean']:7.2f}  [{lo:6.2f}, {hi:6.2f}]"


def _text(payload: dict[str, Any]) -> str:
    lines = [f"{'time':>8s}  {'C_x':>7s}  90% interval      ready"]
    for r in payload["trajectory"]:
        minutes = r["time_s"] / 60.0
        flag = "yes" if r["enough_evidence"] else "no"
        text = _value_text(r["c_x"], r["reason"])
        alarm = {
            "change": "  CHANGE ALARM: restarted from the type prior",
            "swap": "  SWAP ALARM: a new tyre since the drive start, learned from it",
            "": "",
        }[r["alarm_kind"]]
        lines.append(f"{minutes:6.1f} min  {text}  {flag}{alarm}")
    final = payload["final"]
    mu = final["mu_max"]
    lines.append(
        "mu_max  " + (_value_text(mu, None) if mu is not None else f"—  ({final['mu_max_reason']})")
    )
    if final["mu_max_note"]:
        lines.append(f"mu_max  NOTE: {final['mu_max_note']}")
    conflict = final["prior_conflict"]
    if conflict:
        lines.append(
            f"NOTE: the tyre's {conflict['coordinate']} lies {conflict['prior_sds']:+.1f} prior "
            "sds from its prior: the model does not fit these windows (check the surface label "
            "and the vehicle file); C_x and mu_max withheld"
        )
    alarms = zip(payload["alarms_s"], payload["alarm_kinds"], strict=True)
    at = ", ".join(f"{t:.0f} s ({alarm})" for t, alarm in alarms)
    lines.append(f"alarms (swap or change) at: {at or 'none'}")
    lines.append(f"note: {LOOKAHEAD_NOTE}")
    lines.extend(_lateral_text(payload["lateral"], payload["lateral_reason"]))
    return "\n".join(lines)


def _lateral_text(lateral: dict | None, reason: str) -> list[str]:
    if lateral is None:
        return [reason]
    lines = []
    for name, key in (
        ("c_y front", "c_y_front"),
        ("c_y rear", "c_y_rear"),
        ("understeer K", "understeer_gradient"),
    ):
        value = lateral[key]
        if value is None:
            lines.append(f"{name:12s} —")
        else:
            lo, hi = value["hdi_90"]
            lines.append(f"{name:12s} {value['mean']:.4g}  [{lo:.4g}, {hi:.4g}]")
    if lateral["reason"]:
        lines.append(lateral["reason"])
    return lines


def _lateral(path, vehicle_name: str, surface: str) -> dict:
    """The online lateral estimate of a stream: the output's ``"lateral_reason"`` ("" when
    there is a ``"lateral"`` object) and ``"lateral"`` (null until the understeer gradient is
    identified)."""
    from .._domain import load_vehicle
    from ..inference.lateral import NoCornering, cornering_observations
    from ..inference.online.lateral import online_lateral
    from ..inference.online.lateral_blocks import lateral_blocks
    from ..streams import read_stream, validate_stream

    try:
        vehicle = load_vehicle(vehicle_name)
    except ValueError as err:
        raise BadInputError(str(err).splitlines()[0]) from None
    validated = validate_stream(read_stream(path), vehicle)
    try:
        obs = cornering_observations(validated.data, vehicle)
    except NoCornering as err:
        return {"lateral_reason": str(err), "lateral": None}
    return online_lateral(lateral_blocks(obs), surface=surface).to_dict()


def run(args: argparse.Namespace) -> int:
    if args.figure is not None:
        output_file(args.figure, option="--figure", suffixes=(".png",))
    check_ambient(args.ambient)
    import jax

    # The slip signal is ~1e-3 and its noise ~1e-4: the Newton steps need float64.
    jax.config.update("jax_enable_x64", True)
    import numpy as np

    from ..inference.online import STEP_S, online_estimate, stream_steps, stream_windows
    from ..inference.tyre.model import TyrePriors

    with stream_file(args, args.vehicle) as path:
        windows = stream_windows(
            path,
            args.vehicle,
            surface=args.surface,
            temperature_c=args.temperature,
            ambient_c=args.ambient,
        )
        lateral = _lateral(path, args.vehicle, args.surface)
    steps = stream_steps(windows, args.surface, max_step_s=args.max_step_s)
    imu_sd = windows.imu_gain_log_sd
    imu = 0.0 if imu_sd is None else float(np.max(imu_sd, initial=0.0))
    priors = TyrePriors().with_load_sensitivity() if args.load_sensitivity else None
    estimate = online_estimate(steps, model=args.model, priors=priors, imu_gain_log_sd=imu)
    payload = {
        "stream": args.stream,
        "vehicle": args.vehicle,
        "surface": args.surface,
        "model": args.model,
        "load_sensitivity": bool(args.load_sensitivity),
        "step_s": STEP_S,
        "max_step_s": STEP_S if args.max_step_s is None else args.max_step_s,
        **estimate.to_dict(),  # trajectory, final, alarms_s, alarm_kinds
        "note": LOOKAHEAD_NOTE,
    }
    if args.figure is not None:
        payload["figure"] = _figure(args, windows, steps, estimate.trajectory, payload["alarms_s"])
    # The lateral object comes last (the interface the checks read).
    payload.update(lateral)  # lateral_reason, lateral
    if args.json:
        print_json(payload)
    else:
        print(_text(payload))
    return 0


def _figure(args, windows, steps, trajectory, alarms_s: list[float]) -> str:
    import numpy as np

    from .._io import atomic_write_bytes
    from ..inference.online import linear_ekf
    from ..inference.tyre.data import stack_drives
    from ..inference.tyre.fit import fit_tyre
    from ..inference.tyre.model import TyrePriors
    from ..report.online_figure import online_trajectory_figure

    priors = TyrePriors().with_load_sensitivity() if args.load_sensitivity else None
    obs = stack_drives([windows], [args.surface])
    fit = fit_tyre(obs, priors=priors, method="fast", model=args.model)
    if not fit.diagnostics.converged:
        raise BadInputError(f"--figure: the batch fit did not converge ({fit.diagnostics.reason})")
    batch = fit.summary()["c_x"]
    ekf = linear_ekf(steps)
    png = online_trajectory_figure(
        np.asarray(trajectory.time_s),
        np.asarray(trajectory.c_x.mean),
        np.asarray(trajectory.c_x.low),
        np.asarray(trajectory.c_x.high),
        np.asarray(trajectory.ready),
        alarms_s=np.asarray(alarms_s),
        batch=batch,
        baseline=(np.asarray(ekf.time_s), np.asarray(ekf.c_x_mean), np.asarray(ekf.c_x_sd)),
        title=f"{Path(args.stream).name}: C_x online ({args.model}) against the batch posterior",
    )
    atomic_write_bytes(args.figure, png)
    return str(args.figure)
