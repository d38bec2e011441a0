"""``tyrebayes inspect STREAM --vehicle VEHICLE [--json]``: validate and summarise a stream."""

from __future__ import annotations

import argparse
import dataclasses
import math
from typing import Any

import numpy as np

from .._errors import BadInputError
from ._common import add_can_arguments, print_json, stream_file


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "inspect",
        help="validate a sensor stream and summarise it",
        description=(
            "Validate a stream file (CSV, Parquet or MDF4) and summarise it: duration, rate, "
            "dropped samples, noise per channel, driving regimes, sensor nuisances and, with a "
            "speed_reference column, the error of V_x against it."
        ),
    )
    parser.add_argument(
        "stream", help="stream file (.csv, .parquet, .mf4), or a CAN log with --profile"
    )
    parser.add_argument(
        "--vehicle", required=True, help="vehicle preset name (e.g. suv_rav4) or TOML path"
    )
    parser.add_argument(
        "--channel-map",
        metavar="SRC=DST",
        nargs="*",
        default=(),
        help="rename source channels to contract names, e.g. WhlSpdFL=wheel_speed_fl",
    )
    add_can_arguments(parser)
    parser.add_argument("--json", action="store_true", help="machine-readable output")
    parser.set_defaults(func=run)


def _channel_map(pairs: list[str] | tuple[str, ...]) -> dict[str, str]:
    mapping = {}
    for pair in pairs:
        src, sep, dst = pair.partition("=")
        if not sep or not src or not dst:
            raise BadInputError(f"--channel-map: expected SRC=DST, got {pair!r}")
        mapping[src] = dst
    return mapping


def summarize_stream(path, vehicle_name: str, channel_map: dict[str, str]) -> dict[str, Any]:
    """The ``inspect`` summary as a JSON-ready dict (raises BadInputError on bad input)."""
    from .._domain import load_vehicle
    from ..streams import compute_features, read_stream, speed_error, validate_stream

    try:
        vehicle = load_vehicle(vehicle_name)
    except ValueError as err:
        raise BadInputError(str(err).splitlines()[0]) from None
    stream = validate_stream(read_stream(path, channel_map or None), vehicle)
    features = compute_features(stream, vehicle)
    nuis = features.nuisances
    summary: dict[str, Any] = {
        "file": str(path),
        "vehicle": vehicle_name,
        "duration_s": stream.duration_s,
        "sample_rate_hz": stream.sample_rate_hz,
        "samples": int(stream.data.shape[0]),
        "resampled": stream.resampled,
        "channel_rate_hz": stream.channel_rate_hz,
        "nan_fraction": stream.nan_fraction,
        "filled_fraction": float(np.mean(stream.filled)),
        "gaps": [list(g) for g in stream.gaps],
        "segments": features.segments(),
        "noise": stream.noise,
        "quantisation": stream.quantisation,
        "nuisances": {
            "radius_ratio": nuis.radius_ratio,
            "radius_ratio_sd": nuis.radius_ratio_sd,
            "radius_ratio_seconds": nuis.radius_ratio_seconds,
            "ax_offset_mps2": nuis.ax_offset_mps2,
            "ax_offset_sd_mps2": nuis.ax_offset_sd_mps2,
            "pitch_offset_deg": math.degrees(nuis.pitch_offset_rad),
            "ax_gain": dataclasses.asdict(nuis.ax_gain),
            "ay_offset_mps2": nuis.ay_offset_mps2,
            "speed_scale": nuis.speed_scale,
            "speed_scale_sd": nuis.speed_scale_sd,
            "rho_offset_sd": nuis.rho_offset_sd,
        },
        "smoothed_noise": nuis.smoothed_noise,
        "features": {
            "vx_mps_mean": float(np.nanmean(features.vx_mps)) if features.valid.any() else None,
            "slip_driven_p05_p50_p95": _quantiles(features.slip_driven[features.valid]),
            "rho_driven_p05_p50_p95": _quantiles(features.rho_driven[features.valid]),
            "slip_driven_sd_median": _median(features.slip_driven_sd[features.valid]),
            "rho_driven_sd_median": _median(features.rho_driven_sd[features.valid]),
            "vx_source": features.vx_source,
            "driven_axle": features.driven_axle,
        },
        "notes": list(stream.notes),
        "flags": list(stream.flags),
    }
    if "speed_reference" in stream.data:
        summary["speed_error"] = speed_error(
            features, stream.data["speed_reference"].to_numpy(dtype=float)
        )
    return summary


def _quantiles(x: np.ndarray) -> list[float] | None:
    x = x[np.isfinite(x)]
    return np.quantile(x, [0.05, 0.5, 0.95]).tolist() if x.size else None


def _median(x: np.ndarray) -> float | None:
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else None


def _text(summary: dict[str, Any]) -> str:
    lines = [
        f"{summary['file']}: {summary['duration_s']:.1f} s at {summary['sample_rate_hz']:.1f} Hz "
        f"({summary['samples']} samples{', resampled' if summary['resampled'] else ''})",
        "segments: "
        + ", ".join(
            f"{k} {v['seconds']:.1f} s ({v['count']})" for k, v in summary["segments"].items()
        ),
        "noise: " + ", ".join(f"{k} {v:.3g}" for k, v in summary["noise"].items()),
        "dropped: "
        + (
            ", ".join(f"{k} {100 * v:.1f}%" for k, v in summary["nan_fraction"].items() if v > 0)
            or "none"
        ),
    ]
    n = summary["nuisances"]
    lines.append(
        f"IMU ax offset {n['ax_offset_mps2']:.3f} ± {n['ax_offset_sd_mps2']:.3f} m/s² "
        f"(pitch {n['pitch_offset_deg']:.2f}°); radius ratios {np.round(n['radius_ratio'], 4)}"
    )
    g = n["ax_gain"]
    lines.append(
        f"IMU ax gain {g['estimate']:.3f} ± {g['estimate_sd']:.3f} against dV_x/dt "
        f"(P(uncalibrated) {g['p_uncalibrated']:.2f}; ax divided by {g['applied']:.3f})"
    )
    if "speed_error" in summary:
        e = summary["speed_error"]
        lines.append(
            f"V_x vs speed_reference: mean {e['mean_mps']:+.3f} m/s, rms {e['rms_mps']:.3f} m/s, "
            f"scale {100 * e['relative_mean']:+.2f}%, "
            f"rms after scale {e['rms_after_scale_mps']:.3f} m/s"
        )
    lines.extend(f"note: {note}" for note in summary["notes"])
    lines.extend(f"flag: {flag}" for flag in summary["flags"])
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    with stream_file(args, args.vehicle) as path:
        summary = summarize_stream(path, args.vehicle, _channel_map(args.channel_map))
    summary["file"] = str(args.stream)
    if args.json:
        print_json(summary)
    else:
        print(_text(summary))
    return 0
