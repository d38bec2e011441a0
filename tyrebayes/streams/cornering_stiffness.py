"""The per-axle cornering stiffness behind a drive's lateral friction work, and its type prior.

The lateral work's slip angle needs each axle's c_y (yaw rate and lateral acceleration fix F_y,
not the split of δ − L ψ̇ / V between the axles' slip angles): an inferred axle stiffness where a
lateral posterior exists (:func:`tyrebayes.inference.wear.cornering_stiffness_from_lateral`),
otherwise the type prior :data:`TYPE_PRIOR_CORNERING`.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np


class CorneringStiffness(eqx.Module):
    """Per-axle cornering stiffness over axle load used for the lateral slip angle.

    Attributes
    ----------
    front_per_rad, rear_per_rad : float
        c_y of the front and rear axle [1/rad] (median).
    log_sd : float
        Their uncertainty as a log-sd [-]; the wear fit carries it as the scale error of the
        lateral work (W_y ∝ 1 / c_y).
    source : str
        ``"lateral_fit"`` (an inferred axle stiffness), ``"type_prior"`` or ``"given"``.

    Examples
    --------
    >>> CorneringStiffness(18.0, 20.0, 0.1, "given").rear_per_rad
    20.0
    """

    front_per_rad: float
    rear_per_rad: float
    log_sd: float
    source: str = eqx.field(static=True, default="given")

    def __check_init__(self):
        for name in ("front_per_rad", "rear_per_rad"):
            value = float(getattr(self, name))
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"CorneringStiffness.{name}: expected > 0 [1/rad], got {value}")
        if not (np.isfinite(self.log_sd) and self.log_sd >= 0):
            raise ValueError(f"CorneringStiffness.log_sd: expected >= 0, got {self.log_sd}")

    @property
    def per_axle(self) -> np.ndarray:
        """(front, rear) [1/rad]."""
        return np.array([self.front_per_rad, self.rear_per_rad], dtype=float)


#: c_y where no lateral posterior exists: the median of the measured car and SUV tyres'
#: K_y / F_z at nominal load (16.5 /rad, the lateral model's prior median,
#: :class:`tyrebayes.inference.lateral.model.LateralPriors`) with that prior's log-sd 0.5 (an
#: axle's value includes compliance steer, load and pressure).
TYPE_PRIOR_CORNERING = CorneringStiffness(16.5, 16.5, 0.5, "type_prior")
