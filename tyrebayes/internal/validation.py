"""Value checks shared by the parameter modules.

Concrete values (Python numbers, NumPy arrays, concrete JAX arrays) are checked eagerly and raise a
``ValueError`` naming the field, the expectation and the value. Traced values cannot be inspected at
trace time; they pass here and functions that need run-time checks use ``eqx.error_if``.
"""

from __future__ import annotations

import jax
import numpy as np


def _concrete(value) -> np.ndarray | None:
    if isinstance(value, jax.core.Tracer):
        return None
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None


def check_positive(owner: str, field: str, value) -> None:
    """Raise ValueError unless every element of ``value`` is finite and > 0."""
    arr = _concrete(value)
    if arr is not None and not (np.all(np.isfinite(arr)) and np.all(arr > 0)):
        raise ValueError(f"{owner}.{field}: expected a finite value > 0, got {value!r}")


def check_positive_or_inf(owner: str, field: str, value) -> None:
    """Raise ValueError unless every element of ``value`` is > 0 (``inf`` allowed, NaN not)."""
    arr = _concrete(value)
    if arr is not None and not np.all(arr > 0):
        raise ValueError(f"{owner}.{field}: expected values > 0 (inf allowed), got {value!r}")


def check_nonnegative(owner: str, field: str, value) -> None:
    """Raise ValueError unless every element of ``value`` is finite and >= 0."""
    arr = _concrete(value)
    if arr is not None and not (np.all(np.isfinite(arr)) and np.all(arr >= 0)):
        raise ValueError(f"{owner}.{field}: expected a finite value >= 0, got {value!r}")


def check_in_range(owner: str, field: str, value, lo: float, hi: float) -> None:
    """Raise ValueError unless every element of ``value`` lies in the closed range [lo, hi]."""
    arr = _concrete(value)
    if arr is not None and not (np.all(np.isfinite(arr)) and np.all((arr >= lo) & (arr <= hi))):
        raise ValueError(f"{owner}.{field}: expected a value in [{lo}, {hi}], got {value!r}")
