"""Helpers shared by the CLI sub-commands: JSON output, input checks, the exit status of a fit."""

from __future__ import annotations

import contextlib
import json
import math
import os
import stat
import sys
import tempfile
from pathlib import Path

from .._errors import BadInputError
from .._io import atomic_output as atomic_output
from .._io import atomic_path as atomic_path
from .._io import atomic_write_bytes as atomic_write_bytes
from .._io import to_jsonable as _to_jsonable

#: Exit status of a command whose fit did not converge (its result is still written and printed).
EXIT_NOT_CONVERGED = 3
#: Exit status of a batch command that finished with failed items (the rest is written).
EXIT_FAILURES = 4


def print_json(payload: dict) -> None:
    """Print a JSON object on stdout (NaN/inf become null, arrays become lists)."""
    json.dump(_to_jsonable(payload), sys.stdout, indent=2)
    sys.stdout.write("\n")


def existing_file(path: str) -> Path:
    """Return ``path`` as a Path, or raise BadInputError if it is not a readable file.

    The message says what the path is instead: a folder, a device or pipe, a broken link or a
    link loop, a file without read permission, or nothing at all.
    """
    p = Path(path)
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        if p.is_symlink():
            raise BadInputError(f"expected a readable file, got the broken link '{path}'") from None
        raise BadInputError(f"file not found: expected a readable file, got '{path}'") from None
    except OSError as err:  # ELOOP, ENAMETOOLONG, EACCES on a parent folder
        raise BadInputError(f"expected a readable file, got '{path}' ({err.strerror})") from None
    if stat.S_ISDIR(mode):
        raise BadInputError(f"expected a readable file, got the folder '{path}'")
    if not stat.S_ISREG(mode):
        raise BadInputError(
            f"expected a readable file, got '{path}', a device, pipe or socket (not a regular file)"
        )
    if not os.access(p, os.R_OK):
        raise BadInputError(f"expected a readable file, got '{path}' (no read permission)")
    return p


# A saved fit is netCDF-4 (HDF5 inside); netCDF-3 files start with "CDF".
_FIT_SIGNATURES = (b"\x89HDF\r\n\x1a\n", b"CDF\x01", b"CDF\x02")


def fit_file(path: str, what: str = "a saved fit (netCDF from fit-tyre or fit-fleet)") -> Path:
    """Check that ``path`` is a netCDF file before the fit reader opens it.

    A stream or fleet table given where a fit belongs then says so, instead of the HDF5
    library's "file signature not found".
    """
    p = existing_file(path)
    with p.open("rb") as fh:
        head = fh.read(512)
    if head.startswith(_FIT_SIGNATURES):
        return p
    if head.startswith(b"PAR1"):
        got = "a Parquet file (a stream or fleet table?)"
    elif head and b"\x00" not in head:
        got = "text (a CSV stream or fleet table?)"
    else:
        got = "another binary format" if head else "an empty file"
    raise BadInputError(f"fit file {path}: expected {what}, got {got}")


def _nearest_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists (the folder a writer would create under)."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path.cwd()


def _check_creatable(option: str, path: Path) -> None:
    """The folders up to ``path`` exist or can be made, and the nearest existing is writable."""
    base = _nearest_existing(path.parent)
    if not base.is_dir():
        raise BadInputError(
            f"{option}: expected a path under a folder, got '{path}' ('{base}' is a file)"
        )
    if not os.access(base, os.W_OK | os.X_OK):
        raise BadInputError(
            f"{option}: expected a writable folder for '{path}', got '{base}' (not writable)"
        )


def output_file(path: str, option: str = "--out", suffixes: tuple[str, ...] = ()) -> Path:
    """Check an output file name before any work: a fit must not be lost to a bad ``--out``.

    Parameters
    ----------
    path : str
        The file the command will write (created or replaced atomically).
    option : str
        The option's name, for the message.
    suffixes : tuple of str
        Accepted suffixes (lower case, with the dot); empty accepts any.

    Returns
    -------
    Path

    Raises
    ------
    BadInputError
        An existing folder at ``path``, a wrong suffix, a parent that is a file, or a folder that
        is not writable.
    """
    p = Path(path)
    if p.is_dir():
        raise BadInputError(f"{option}: expected a file name, got the existing folder '{path}'")
    if suffixes and not p.name.lower().endswith(suffixes):
        raise BadInputError(
            f"{option}: expected a file name ending in {list(suffixes)}, got {path!r}"
        )
    _check_creatable(option, p)
    return p


def output_folder(path: str, option: str = "--out") -> Path:
    """Check an output folder before any work (it may not exist yet; its parent is made).

    Raises
    ------
    BadInputError
        An existing file at ``path``, or no writable folder to create it in.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise BadInputError(f"{option}: expected a folder, got the file '{path}'")
    _check_creatable(option, p / "x")
    return p


#: Ambient air temperatures the thermal model was built for [°C]: the range of recorded road
#: weather outside deserts and polar winters. Beyond it the rolling-loss and convection terms are
#: extrapolated (and a value like 293 is kelvin).
AMBIENT_RANGE_C = (-40.0, 60.0)


def check_ambient(value: float | None, option: str = "--ambient") -> None:
    """Raise BadInputError for an ambient temperature outside :data:`AMBIENT_RANGE_C`."""
    if value is None:
        return
    lo, hi = AMBIENT_RANGE_C
    if not lo <= value <= hi:
        hint = f" (kelvin? use {value - 273.15:.3g})" if 233.0 <= value <= 333.0 else ""
        raise BadInputError(
            f"{option}: expected an air temperature in [{lo:g}, {hi:g}] °C (the thermal model's "
            f"range), got {value:g}{hint}"
        )


def diagnostics_text(diagnostics) -> str:
    """Two lines for a human: convergence (R-hat, ESS, divergences) and model adequacy."""
    d = diagnostics
    # Independent draws (the fast path's Laplace draws) have no chains to compare: no R-hat.
    r_hat = "–" if math.isnan(d.r_hat_max) else f"{d.r_hat_max:.3f}"
    first = (
        f"method {d.method}: R-hat max {r_hat}, ESS min bulk {d.ess_bulk_min:.0f} / "
        f"tail {d.ess_tail_min:.0f}, divergences {d.divergences}; "
        + ("converged" if d.converged else f"NOT CONVERGED: {d.reason}")
    )
    second = (
        "model adequate"
        if d.adequate and not d.adequacy_reasons
        else ("model adequate, but: " if d.adequate else "MODEL INADEQUATE: ")
        + "; ".join(d.adequacy_reasons)
    )
    return f"{first}\n{second}"


def add_can_arguments(parser) -> None:
    """``--profile``, ``--dbc``, ``--bus``: read the input as a raw CAN log with a car profile."""
    parser.add_argument(
        "--profile",
        default=None,
        help="car profile name (e.g. toyota_rav4_2017) or TOML path: the input is a raw CAN log "
        "(.log candump, .asc, .blf, .csv python-can, .mf4 bus logging) decoded with its DBC",
    )
    parser.add_argument(
        "--dbc", default=None, help="with --profile: a DBC instead of the profile's"
    )
    parser.add_argument(
        "--bus", default=None, help="with --profile: use frames of this bus only (e.g. can0, 0)"
    )
    parser.add_argument(
        "--max-time-faults",
        type=_fraction,
        default=None,
        metavar="FRACTION",
        help="with --profile: the fraction of a message's frames that may be out of time order "
        "or duplicated (default 0.01); up to it they are dropped (a reversed log sorted) with a "
        "warning on stderr, above it the log is refused; 0 refuses any",
    )


def _fraction(text: str) -> float:
    """An argparse type: a number in [0, 1] (a fraction, not a percentage)."""
    import argparse

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a fraction in [0, 1], got {text!r}") from None
    if not 0.0 <= value <= 1.0:
        hint = " (a percentage? divide by 100)" if 1.0 < value <= 100.0 else ""
        raise argparse.ArgumentTypeError(f"expected a fraction in [0, 1], got {text}{hint}")
    return value


def max_time_faults(args) -> float:
    """``--max-time-faults``, or the library's default."""
    from ..streams.can.time_faults import DEFAULT_MAX_TIME_FAULTS

    value = getattr(args, "max_time_faults", None)
    return DEFAULT_MAX_TIME_FAULTS if value is None else value


def warn_time_faults(args, conversion) -> None:
    """One line on stderr when a CAN log's time faults were repaired (they are in the JSON)."""
    text = conversion.time_faults_text()
    if text:
        print(f"tyrebayes {args.command}: warning: {text}", file=sys.stderr)


@contextlib.contextmanager
def stream_file(args, vehicle: str | None = None):
    """The stream file of a command: ``args.stream``, or a CAN log decoded into a temporary file.

    With ``--profile`` the log is decoded (:func:`tyrebayes.streams.can.read_can_log`, wheel
    speeds converted with ``vehicle``'s nominal radius, time faults up to ``--max-time-faults``
    repaired with a warning line) and written to a temporary Parquet file that lives for the
    ``with`` block, so that commands that read stream files take CAN logs unchanged.
    """
    if getattr(args, "profile", None) is None:
        for name in ("dbc", "bus", "max_time_faults"):
            if getattr(args, name, None) is not None:
                option = f"--{name.replace('_', '-')}"
                raise BadInputError(f"{option}: expected together with --profile, got it alone")
        yield existing_file(args.stream)
        return
    from ..streams import write_stream
    from ..streams.can import read_can_log

    conversion = read_can_log(
        existing_file(args.stream),
        args.profile,
        dbc=args.dbc,
        vehicle=vehicle,
        bus=args.bus,
        max_time_faults=max_time_faults(args),
    )
    warn_time_faults(args, conversion)
    with tempfile.TemporaryDirectory(prefix="tyrebayes-can-") as tmp:
        path = Path(tmp) / f"{Path(args.stream).stem}.parquet"
        write_stream(conversion.data, path)
        yield path


def save_fit(fit, path: str | os.PathLike) -> str:
    """Write a fit to ``--out`` whole or not at all: a signal while it is written leaves the
    previous file and no temporary one (:func:`tyrebayes._io.atomic_output`)."""
    with atomic_output(path) as tmp:
        fit.save(tmp)
    return str(path)


def exit_status(fit, command: str) -> int:
    """0 for a converged fit; :data:`EXIT_NOT_CONVERGED` (with the reason on stderr) otherwise."""
    if fit.diagnostics.converged:
        return 0
    print(f"tyrebayes {command}: fit did not converge: {fit.diagnostics.reason}", file=sys.stderr)
    return EXIT_NOT_CONVERGED
