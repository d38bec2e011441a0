"""Locate the reviewed numbers in ``models/`` and the shipped data in ``tyrebayes/data/``.

In a wheel, ``models/`` is installed as ``tyrebayes/_models``; in a source checkout (editable
install) it is the ``models/`` folder beside the package.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def models_dir() -> Path:
    """The folder holding ``vehicles/*.toml`` and the tyre-type priors."""
    for candidate in (_PACKAGE_DIR / "_models", _PACKAGE_DIR.parent / "models"):
        if candidate.is_dir():
            return candidate
    raise FileNotFoundError(
        f"models folder not found: expected {_PACKAGE_DIR / '_models'} or "
        f"{_PACKAGE_DIR.parent / 'models'}"
    )


def data_dir() -> Path:
    """The folder of data shipped with the package (real log, measured tables)."""
    return _PACKAGE_DIR / "data"
