"""The in-car lateral estimator's coordinates: the batch model's sites it reads, each axle's λ.

The estimator (:mod:`.lateral`) carries the linear-range model's parameters and, per axle, the
curve's cubic term λ in place of the batch model's Magic Formula shape.
"""

from __future__ import annotations

from ..lateral.model import LateralPriors, sample_sites

#: The batch model's sites the linear-range model reads, in its order.
LINEAR_SITES = (
    "c_y_front",
    "c_y_rear",
    "steering_ratio",
    "steering_offset",
    "ay_offset",
    "roll_gradient",
    "yaw_inertia_factor",
    "curve_cubic_front",
    "curve_cubic_rear",
)
#: The estimator's coordinates that are not the batch model's sample sites: each axle's λ (the
#: front's alone, serving both axles, where the priors leave out ``axle_shapes``).
CUBIC_SITES = ("curve_cubic_front", "curve_cubic_rear")


def linear_sites(priors: LateralPriors) -> tuple[str, ...]:
    """The estimator's coordinates: :data:`LINEAR_SITES` whose effects ``priors`` carry.

    Examples
    --------
    >>> linear_sites(LateralPriors())[:3]
    ('c_y_front', 'c_y_rear', 'steering_ratio')
    >>> "roll_gradient" in linear_sites(LateralPriors().without("roll"))
    False
    """
    cubic = CUBIC_SITES if "axle_shapes" in priors.effects else CUBIC_SITES[:1]
    full = (*sample_sites(priors), *cubic)
    return tuple(n for n in LINEAR_SITES if n in full)
