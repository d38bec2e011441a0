"""``tyrebayes convert LOG --profile NAME|PATH [--dbc FILE] --out STREAM.parquet [--json]``.

Decodes a raw CAN log with a car profile's DBC, validates it and puts it on one time base with
the stream pipeline (:func:`tyrebayes.streams.validate_stream`), and writes a stream file in the
DESIGN.md contract (Parquet, CSV or MDF4 by the suffix). The output appears complete or not at
all. Exit status 2 with one line on stderr on a bad log, profile or DBC.

Time faults (:mod:`tyrebayes.streams.can.time_faults`: frames whose timestamps go back, frames
written twice, a reversed log) are counted per message: above ``--max-time-faults`` (default 1 %
of a message's frames) the log is refused with exit 2 and one line; up to it they are repaired
(dropped; a reversed message sorted), counted in the JSON (``time_faults``) and named in a
warning line on stderr.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from .._errors import BadInputError
from ._common import (
    add_can_arguments,
    existing_file,
    max_time_faults,
    output_file,
    print_json,
    warn_time_faults,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "convert",
        help="decode a raw CAN log with a car profile into a stream file",
        description=(
            "Decode a CAN log (candump .log, Vector .asc/.blf, python-can .csv, MF4 bus logging, "
            "a comma raw_can folder or .npz) "
            "with a car profile and its DBC, validate and resample it onto one time base, and "
            "write a stream file (.parquet, .csv or .mf4)."
        ),
    )
    parser.add_argument("log", help="CAN log file, or a comma raw_can folder")
    add_can_arguments(parser)
    parser.add_argument(
        "--vehicle",
        default=None,
        help="vehicle preset or TOML path for the wheel radius (default: the profile's)",
    )
    parser.add_argument(
        "--out",
        required=True,
        help="stream file to write (.parquet, .csv, .mf4; missing folders are created)",
    )
    parser.add_argument("--json", action="store_true", help="machine-readable output")
    parser.set_defaults(func=run)


def convert_log(args: argparse.Namespace) -> dict[str, Any]:
    """Decode, validate and write; the summary as a JSON-ready dict."""
    from .._domain import load_vehicle
    from ..streams import write_stream
    from ..streams.can import load_profile, read_can_log, validate_conversion
    from ..streams.io import SUPPORTED_SUFFIXES

    if not args.out.lower().endswith(SUPPORTED_SUFFIXES):
        raise BadInputError(
            f"--out: expected a stream file name ending in {list(SUPPORTED_SUFFIXES)}, "
            f"got {args.out!r}"
        )
    output_file(args.out)
    if args.profile is None:
        raise BadInputError("--profile: expected a car profile name or TOML path, got none")
    profile = load_profile(args.profile)
    try:
        vehicle = load_vehicle(args.vehicle or profile.vehicle)
    except ValueError as err:
        raise BadInputError(str(err).splitlines()[0]) from None
    # A comma raw_can log is a folder of arrays; every other log is one file.
    log = Path(args.log) if Path(args.log).is_dir() else existing_file(args.log)
    conv = read_can_log(
        log,
        profile,
        dbc=args.dbc,
        vehicle=vehicle,
        bus=args.bus,
        max_time_faults=max_time_faults(args),
    )
    warn_time_faults(args, conv)
    stream = validate_conversion(conv, profile, vehicle)
    write_stream(stream.data, args.out)
    data = stream.data
    counts = conv.counts
    return {
        "log": str(args.log),
        "profile": profile.name,
        "dbc": str(profile.dbc_path(args.dbc)),
        "vehicle": args.vehicle or profile.vehicle,
        "out": str(args.out),
        "frames_read": counts.frames,
        "error_frames_skipped": counts.error_frames,
        "remote_frames_skipped": counts.remote_frames,
        "frames_other_bus": counts.other_bus,
        "buses": list(counts.buses),
        "frames_used": counts.kept,
        "frames_used_per_message": conv.frames_per_message,
        # Per message: frames duplicated or out of time order (dropped; a reversed log sorted).
        "time_faults": {name: f.as_dict() for name, f in conv.time_faults.items()},
        "time_faults_repaired": conv.time_faults_repaired,
        "max_time_faults": max_time_faults(args),
        "invalid_samples_per_channel": conv.invalid_per_column,
        "time_origin_s": conv.time_origin_s,
        "duration_s": stream.duration_s,
        "sample_rate_hz": stream.sample_rate_hz,
        "samples": int(data.shape[0]),
        "channel_rate_hz": stream.channel_rate_hz,
        "nan_fraction": {
            c: float(np.mean(~np.isfinite(data[c].to_numpy(dtype=float))))
            for c in data.columns
            if c != "time"
        },
        "resampled": stream.resampled,
        "notes": list(stream.notes),
        "flags": list(stream.flags),
    }


def _text(summary: dict[str, Any]) -> str:
    per_message = ", ".join(f"{k} {v}" for k, v in summary["frames_used_per_message"].items())
    rates = ", ".join(f"{k} {v:.1f} Hz" for k, v in summary["channel_rate_hz"].items())
    dropped = ", ".join(f"{k} {100 * v:.1f}%" for k, v in summary["nan_fraction"].items() if v > 0)
    lines = [
        f"{summary['log']} -> {summary['out']}: {summary['samples']} samples, "
        f"{summary['duration_s']:.1f} s at {summary['sample_rate_hz']:.1f} Hz",
        f"frames: {summary['frames_read']} read, {summary['frames_used']} used ({per_message}); "
        f"skipped {summary['error_frames_skipped']} error, {summary['remote_frames_skipped']} "
        f"remote, {summary['frames_other_bus']} on other buses",
        f"rates: {rates}",
        f"NaN: {dropped or 'none'}",
    ]
    repaired = [
        f"{k} {f['duplicates'] + f['out_of_order']}"
        for k, f in summary["time_faults"].items()
        if f["duplicates"] + f["out_of_order"]
    ]
    lines.append(f"time faults repaired: {', '.join(repaired) or 'none'}")
    lines.extend(f"note: {note}" for note in summary["notes"])
    lines.extend(f"flag: {flag}" for flag in summary["flags"])
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    summary = convert_log(args)
    if args.json:
        print_json(summary)
    else:
        print(_text(summary))
    return 0
