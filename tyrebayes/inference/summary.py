"""Scalar posterior summaries in the package's JSON contract: :class:`PosteriorSummary`."""

from __future__ import annotations

import dataclasses

import arviz_stats as azs
import numpy as np


@dataclasses.dataclass(frozen=True)
class PosteriorSummary:
    """Mean, standard deviation and highest-density interval of the draws of one scalar.

    Every field is in the unit of the draws summarised (N/unit slip for C_x, km/h for a
    critical speed, ...). NaN where the draws cannot give it (no finite draw; an interval of
    fewer than three distinct draws).

    Attributes
    ----------
    mean : float
        Mean of the finite draws.
    sd : float
        Standard deviation of the finite draws (``ddof=1``; ``ddof=0`` for fewer than three
        draws or equal ones).
    hdi_low : float
        Lower end of the highest-density interval.
    hdi_high : float
        Upper end of the highest-density interval.
    hdi_prob : float
        Probability mass of the interval (0.9 by default).

    Examples
    --------
    >>> s = PosteriorSummary(mean=30.0, sd=2.0, hdi_low=26.7, hdi_high=33.3, hdi_prob=0.9)
    >>> s.hdi_key, s.to_dict()
    ('hdi_90', {'mean': 30.0, 'sd': 2.0, 'hdi_90': [26.7, 33.3]})
    """

    mean: float
    sd: float
    hdi_low: float
    hdi_high: float
    hdi_prob: float = 0.9

    @property
    def hdi_key(self) -> str:
        """The interval's key in :meth:`to_dict`: ``"hdi_90"`` for ``hdi_prob`` 0.9."""
        return f"hdi_{round(100 * self.hdi_prob)}"

    def to_dict(self) -> dict:
        """``{"mean", "sd", "hdi_90": [lo, hi]}`` (the interval's key from ``hdi_prob``), the
        form every command's JSON gives a posterior in."""
        return {"mean": self.mean, "sd": self.sd, self.hdi_key: [self.hdi_low, self.hdi_high]}


def summarize(samples, hdi_prob: float = 0.9) -> PosteriorSummary:
    """Summarise draws of a scalar: mean, sd and highest-density interval.

    Parameters
    ----------
    samples : array_like
        Draws of one scalar quantity, any shape (chains × draws are flattened); non-finite
        draws are left out.
    hdi_prob : float
        Probability mass of the highest-density interval (0.9 gives the ``hdi_90`` key).

    Returns
    -------
    PosteriorSummary
        In the unit of the draws; ``to_dict()`` gives ``{"mean": float, "sd": float,
        "hdi_90": [lo, hi]}`` (key named after ``hdi_prob``).

    Examples
    --------
    >>> s = summarize(np.random.default_rng(0).normal(30.0, 2.0, 4000))
    >>> round(s.mean), round(s.sd), s.hdi_low < 30.0 < s.hdi_high
    (30, 2, True)
    >>> sorted(s.to_dict())
    ['hdi_90', 'mean', 'sd']
    """
    x = np.asarray(samples, dtype=float).ravel()
    x = x[np.isfinite(x)]
    nan = float("nan")
    if x.size == 0:
        return PosteriorSummary(nan, nan, nan, nan, hdi_prob)
    if x.size < 3 or np.ptp(x) == 0:
        lo = hi = float(x[0]) if np.ptp(x) == 0 else nan
        return PosteriorSummary(float(x.mean()), float(x.std()), lo, hi, hdi_prob)
    lo, hi = np.asarray(azs.hdi(x, prob=hdi_prob))
    return PosteriorSummary(float(x.mean()), float(x.std(ddof=1)), float(lo), float(hi), hdi_prob)
