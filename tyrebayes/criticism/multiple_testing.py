"""Multiple-testing corrections over a scan's candidates: Holm and Benjamini-Hochberg.

The discovery rule (:mod:`tyrebayes.criticism.scan`) controls the false-discovery rate at
:data:`DEFAULT_ALPHA` with :func:`benjamini_hochberg`.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Float

#: False-discovery rate of the rule (Benjamini-Hochberg over candidates).
DEFAULT_ALPHA = 0.05


def holm(p_values: Float[np.ndarray, " m"]) -> Float[np.ndarray, " m"]:
    """Holm step-down adjusted p-values (family-wise error control, any dependence).

    Examples
    --------
    >>> holm(np.array([0.01, 0.04, 0.03])).round(3).tolist()
    [0.03, 0.06, 0.06]
    """
    m = p_values.shape[0]
    order = np.argsort(p_values)
    adj = np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * p_values[order]))
    out = np.empty(m)
    out[order] = adj
    return out


def benjamini_hochberg(p_values: Float[np.ndarray, " m"]) -> Float[np.ndarray, " m"]:
    """Benjamini-Hochberg adjusted p-values (false-discovery-rate control).

    Examples
    --------
    >>> benjamini_hochberg(np.array([0.01, 0.04, 0.03])).round(3).tolist()
    [0.03, 0.04, 0.04]
    """
    m = p_values.shape[0]
    order = np.argsort(p_values)
    ranked = p_values[order] * m / (np.arange(m) + 1.0)
    adj = np.minimum(1.0, np.minimum.accumulate(ranked[::-1])[::-1])
    out = np.empty(m)
    out[order] = adj
    return out
