"""Scalar posterior summaries in the package's JSON contract."""

from __future__ import annotations

import arviz_stats as azs
import numpy as np


def summarize(samples, hdi_prob: float = 0.9) -> dict:
    """Summarise draws of a scalar as ``{"mean", "sd", "hdi_90"}``.

    Parameters
    ----------
    samples : array_like
        Draws of one scalar quantity, any shape (chains × draws are flattened).
    hdi_prob : float
        Probability mass of the highest-density interval (0.9 gives the ``hdi_90`` key).

    Returns
    -------
    dict
        ``{"mean": float, "sd": float, "hdi_90": [lo, hi]}`` (key named after ``hdi_prob``).

    Examples
    --------
    >>> s = summarize(np.random.default_rng(0).normal(30.0, 2.0, 4000))
    >>> round(s["mean"])
    30
    """
    x = np.asarray(samples, dtype=float).ravel()
    x = x[np.isfinite(x)]
    key = f"hdi_{round(100 * hdi_prob)}"
    if x.size == 0:
        return {"mean": float("nan"), "sd": float("nan"), key: [float("nan"), float("nan")]}
    if x.size < 3 or np.ptp(x) == 0:
        lo = hi = float(x[0]) if np.ptp(x) == 0 else float("nan")
        return {"mean": float(x.mean()), "sd": float(x.std()), key: [lo, hi]}
    lo, hi = np.asarray(azs.hdi(x, prob=hdi_prob))
    return {"mean": float(x.mean()), "sd": float(x.std(ddof=1)), key: [float(lo), float(hi)]}
