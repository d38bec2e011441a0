"""The batch lateral model's priors as a Gaussian on its unconstrained space.

The sites are the batch model's (:mod:`tyrebayes.inference.lateral.model`), log for the positive
ones: log c_y front and rear, log μ_y, the steering ratio, the steering and a_y offsets, the roll
gradient, the yaw inertia's factor, the curve's shape, and the noise scales of the two equations
and of the axle forces; independent (:func:`lateral_prior`). The online lateral estimator
(:mod:`.lateral`) starts from the sites it reads.
"""

from __future__ import annotations

import math

import equinox as eqx
import numpy as np
from jaxtyping import Array, Float

from ...internal.device_arrays import device_array
from ..lateral.model import LateralPriors, sample_sites


class LateralPrior(eqx.Module):
    """The Gaussian over the unconstrained coordinates the estimator starts from.

    Attributes
    ----------
    mean : Float[Array, "p"]
    cov : Float[Array, "p p"]
    precision : Float[Array, "p p"]
        The inverse of ``cov``.
    names : tuple of str
        The coordinates.
    """

    mean: Float[Array, " p"]
    cov: Float[Array, "p p"]
    precision: Float[Array, "p p"]
    names: tuple[str, ...] = eqx.field(static=True)

    def __init__(self, mean, cov, names):
        self.mean, self.cov, self.names = mean, cov, tuple(names)
        # Inverted once, in NumPy: every Newton step of every block reads it.
        self.precision = device_array(np.linalg.inv(np.asarray(cov)))

    def __check_init__(self):
        p = len(self.names)
        if self.mean.shape != (p,) or self.cov.shape != (p, p):
            raise ValueError(
                f"LateralPrior: expected mean ({p},) and cov ({p}, {p}), "
                f"got {self.mean.shape} and {self.cov.shape}"
            )


def lateral_prior(
    priors: LateralPriors | None = None, *, surface: str = "dry", steering_ratio: float = 15.0
) -> LateralPrior:
    """The batch model's priors as a Gaussian on its unconstrained space (independent sites).

    Examples
    --------
    >>> prior = lateral_prior()
    >>> round(float(np.exp(prior.mean[0])), 2), round(float(np.sqrt(prior.cov[0, 0])), 2)
    (16.5, 0.5)
    """
    priors = LateralPriors() if priors is None else priors
    mu, mu_log_sd = priors.mu_y_prior(surface)
    centre_sd = {
        "c_y_front": (math.log(priors.c_y_median), priors.c_y_log_sd),
        "c_y_rear": (math.log(priors.c_y_median), priors.c_y_log_sd),
        "mu_y": (math.log(mu), mu_log_sd),
        "steering_ratio": (math.log(steering_ratio), priors.steering_ratio_log_sd),
        "steering_offset": (0.0, priors.steering_offset_sd_rad),
        "ay_offset": (0.0, priors.ay_offset_sd),
        "roll_gradient": (math.log(priors.roll_gradient_median), priors.roll_gradient_log_sd),
        "yaw_inertia_factor": (0.0, priors.yaw_inertia_log_sd),
        "relaxation_length": (
            math.log(priors.relaxation_length_median_m),
            priors.relaxation_length_log_sd,
        ),
        **{
            f"curve_shape_excess_{axle}": (
                priors.curve_shape_excess_log_mean,
                priors.curve_shape_excess_log_sd,
            )
            for axle in ("front", "rear")
        },
        **{
            f"curve_curvature_gap_{axle}": (
                priors.curve_curvature_gap_log_mean,
                priors.curve_curvature_gap_log_sd,
            )
            for axle in ("front", "rear")
        },
        "steer_noise": (math.log(priors.steer_noise_median), 1.0),
        "kinematic_noise": (math.log(priors.kinematic_noise_median), 1.0),
        "force_noise": (math.log(priors.force_noise_median), 1.0),
    }
    names = sample_sites(priors)
    # Built in NumPy: eager JAX operations would each be a small compiled program.
    mean = np.asarray([centre_sd[n][0] for n in names])
    sd = np.asarray([centre_sd[n][1] for n in names])
    return LateralPrior(mean=device_array(mean), cov=device_array(np.diag(sd**2)), names=names)


__all__ = ["LateralPrior", "lateral_prior"]
