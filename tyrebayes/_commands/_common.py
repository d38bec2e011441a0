"""Helpers shared by the CLI sub-commands: JSON output, input checks, the exit status of a fit."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from .._errors import BadInputError
from .._io import atomic_path as atomic_path
from .._io import atomic_write_bytes as atomic_write_bytes
from .._io import to_jsonable as _to_jsonable

#: Exit status of a command whose fit did not converge (its result is still written and printed).
EXIT_NOT_CONVERGED = 3


def print_json(payload: dict) -> None:
    """Print a JSON object on stdout (NaN/inf become null, arrays become lists)."""
    json.dump(_to_jsonable(payload), sys.stdout, indent=2)
    sys.stdout.write("\n")


def existing_file(path: str) -> Path:
    """Return ``path`` as a Path, or raise BadInputError if it is not a readable file."""
    p = Path(path)
    if not p.is_file():
        raise BadInputError(f"file not found: expected a readable file, got '{path}'")
    return p


def diagnostics_text(diagnostics) -> str:
    """Two lines for a human: convergence (R-hat, ESS, divergences) and model adequacy."""
    d = diagnostics
    first = (
        f"method {d.method}: R-hat max {d.r_hat_max:.3f}, ESS min bulk {d.ess_bulk_min:.0f} / "
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


def exit_status(fit, command: str) -> int:
    """0 for a converged fit; :data:`EXIT_NOT_CONVERGED` (with the reason on stderr) otherwise."""
    if fit.diagnostics.converged:
        return 0
    print(f"tyrebayes {command}: fit did not converge: {fit.diagnostics.reason}", file=sys.stderr)
    return EXIT_NOT_CONVERGED
