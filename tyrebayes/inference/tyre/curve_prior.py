"""The prior over the tyre curve's shape, derived from measured tyres.

Normal driving uses a fraction of μ_max, so the slip stiffness C_x (the slope at zero slip) is an
extrapolation through the curve's shape: what a drive measures is the secant slope over the
forces it used, and how that secant relates to the tangent at zero depends on how the curve
bends. The per-tyre model's default curve is the Magic Formula
(:func:`~tyrebayes.physics.tyre.magic_formula_inverse_and_slope`) with its shape factor C and
curvature E unknown; their prior is the spread of the car and SUV tyres in the shipped
database (``models/tyre_curves/mf_longitudinal_sets.csv``, public ``.tir`` files with sources),
so that a drive that cannot tell the shape carries the measured tyres' range of shapes into
C_x, and a drive that can (ABS stops, hard acceleration) narrows it.

The same sets give the prior of the stiffness's load sensitivity q = d ln C_x / d(ΔF_z/F_z0) at
the nominal load, PKX2/PKX1 + PKX3 of C_x = K_x/F_z = (PKX1 + PKX2 dfz) exp(PKX3 dfz) (Pacejka
2006, 4.E15): Normal with their mean and widened sd.

Parametrisation: log(C − 1) and log(1 − E) are Normal (C > 1 gives the curve a peak, E < 1 keeps
it monotone up to the peak). Their means and sds are those of the distinct car/SUV (C, E_traction)
sets, the sds widened by √(1 + 1/n) for the sets' own sampling (the predictive spread of one
more tyre under a Normal model with estimated mean).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from ..._tyre_curve_sets import distinct_passenger_sets


@dataclasses.dataclass(frozen=True)
class CurveShapePrior:
    """Normal priors of log(C − 1) and log(1 − E) of the Magic Formula curve.

    Attributes
    ----------
    shape_excess_log_mean, shape_excess_log_sd : float
        Mean and sd of log(C − 1) [-].
    curvature_log_mean, curvature_log_sd : float
        Mean and sd of log(1 − E) [-].
    load_sensitivity_mean, load_sensitivity_sd : float
        Mean and sd of q = d ln C_x / d(ΔF_z/F_z0) [-].
    n_sets : int
        Distinct measured sets the numbers came from.
    """

    shape_excess_log_mean: float
    shape_excess_log_sd: float
    curvature_log_mean: float
    curvature_log_sd: float
    load_sensitivity_mean: float
    load_sensitivity_sd: float
    n_sets: int


def curve_shape_prior(table: pd.DataFrame | None = None) -> CurveShapePrior:
    """Derive :class:`CurveShapePrior` from the database (see the module docstring).

    Examples
    --------
    >>> prior = curve_shape_prior()
    >>> prior.n_sets
    9
    """
    sets = distinct_passenger_sets(table)
    n = len(sets)
    if n < 3:
        raise ValueError(f"tyre-curve prior: expected at least 3 car/SUV sets, got {n}")
    shape = np.log(sets["C"].to_numpy(dtype=float) - 1.0)
    curvature = np.log(1.0 - sets["E_traction"].to_numpy(dtype=float))
    pkx1, pkx2, pkx3 = (sets[c].to_numpy(dtype=float) for c in ("PKX1", "PKX2", "PKX3"))
    load_sensitivity = pkx2 / pkx1 + pkx3
    widen = np.sqrt(1.0 + 1.0 / n)
    return CurveShapePrior(
        shape_excess_log_mean=float(shape.mean()),
        shape_excess_log_sd=float(shape.std(ddof=1) * widen),
        curvature_log_mean=float(curvature.mean()),
        curvature_log_sd=float(curvature.std(ddof=1) * widen),
        load_sensitivity_mean=float(load_sensitivity.mean()),
        load_sensitivity_sd=float(load_sensitivity.std(ddof=1) * widen),
        n_sets=n,
    )
