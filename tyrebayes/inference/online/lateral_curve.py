"""The tyre curve in the online lateral estimator: the prior of its cubic term, and how far the
series holds.

The estimator (:mod:`.lateral`) takes the batch model's Magic Formula to fifth order,
α = (ρ/c_y)(1 + λρ² + κλ²ρ⁴) (:mod:`.lateral_statistics`). Each axle's λ = k₃/μ_y² is a
parameter with the prior the batch model's priors of the curve's shape C, curvature E and μ_y
imply (:func:`cubic_prior`); κ = k₅/k₃² is taken at the curve priors' medians
(:func:`curve_medians`); and the steering equation reads samples up to :data:`PEAK_SHARE` of
μ_y's prior median.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.special import erfinv

from ...physics.magic_formula import magic_formula_inverse_series
from ..lateral.model import LateralPriors

#: The steering equation reads samples whose axle forces stay below this share of μ_y's prior
#: median on the surface: there, at the curve priors' medians, the series' slip angle is 0.6 %
#: short of the curve's (the tangent's 10 %; the example of
#: :func:`~tyrebayes.physics.magic_formula.magic_formula_inverse_series`), beyond it the
#: series departs fast, and the batch model gives such samples little weight (their slope
#: dα/dρ, and with it their variance, grows towards the peak).
PEAK_SHARE = 0.6


def curve_medians(priors: LateralPriors) -> tuple[float, float]:
    """The batch model's prior medians of the curve's shape C and curvature E.

    Examples
    --------
    >>> [round(x, 3) for x in curve_medians(LateralPriors())]
    [1.344, -0.631]
    """
    return (
        1.0 + math.exp(priors.curve_shape_excess_log_mean),
        1.0 - math.exp(priors.curve_curvature_gap_log_mean),
    )


@functools.lru_cache(maxsize=16)
def cubic_prior(priors: LateralPriors, surface: str = "dry") -> tuple[float, float]:
    """Median and log-sd of λ = ((1 + E)/3 + C²/6)/(C μ_y)² under the batch model's priors of
    the curve's shape C, curvature E and μ_y on ``surface``.

    The batch priors put a little mass on curves whose cubic term is not positive (E far below
    −1 with a small C); the log-sd is therefore read from the central 68 % of λ (half the log
    distance between its 16th and 84th percentiles), over a fixed grid of the three priors'
    quantiles. Kept per priors and surface: a fleet worker creates an estimator per drive.

    Examples
    --------
    >>> m, s = cubic_prior(LateralPriors())
    >>> round(math.exp(m), 3), round(s, 2)
    (0.223, 0.53)
    """
    levels = np.linspace(0.5, 99.5, 100) / 100.0
    z = np.sqrt(2.0) * erfinv(2.0 * levels - 1.0)
    mu_median, mu_log_sd = priors.mu_y_prior(surface)
    shape = 1.0 + np.exp(priors.curve_shape_excess_log_mean + priors.curve_shape_excess_log_sd * z)
    curvature = 1.0 - np.exp(
        priors.curve_curvature_gap_log_mean + priors.curve_curvature_gap_log_sd * z
    )
    mu = mu_median * np.exp(mu_log_sd * z)
    c, e, m = np.meshgrid(shape, curvature, mu, indexing="ij")
    cubic = magic_formula_inverse_series(c, e)[0] / m**2
    low, median, high = np.percentile(cubic, [15.87, 50.0, 84.13])
    return math.log(median), 0.5 * math.log(high / max(low, 1e-12))


__all__ = ["PEAK_SHARE", "cubic_prior", "curve_medians"]
