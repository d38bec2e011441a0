"""The lane change's tyre-parameter draws and where they came from: :class:`VmaxInputs`.

Every path to V_max (the type relations, a fleet's per-type ratio, a lateral posterior) ends in
one :class:`VmaxInputs`: joint draws of the per-axle cornering stiffness c_y and of μ_y, with
``lateral_source`` and ``mu_y_source`` saying which path gave them and ``surface`` the surface
μ_y belongs to.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..summary import summarize

#: Where a prediction's cornering stiffness came from: the fit's lateral posterior, the fleet's
#: per-type ratio (C_y = k · C_xr, k from the fleet fit's posterior predictive for the type), or
#: the type-level relation C_y = k_type · C_xr.
LATERAL_SOURCES = ("measured", "fleet_type_ratio", "type_prior")
#: Where its μ_y came from: the lateral fit (the drive neared the peak), the longitudinal fit's
#: observed μ_max, the lateral posterior without the peak (the surface's prior, bounded below by
#: the forces used), or the type relation μ_y = 0.95 μ_type.
MU_Y_SOURCES = ("measured", "mu_max", "surface_prior", "type_prior")
#: The surface the type relations describe.
TYPE_SURFACE = "dry asphalt (type relations)"


@dataclasses.dataclass(frozen=True)
class VmaxInputs:
    """Joint draws of the lane change's tyre parameters, and where they came from.

    Attributes
    ----------
    c_y_front, c_y_rear : ndarray
        Per-axle cornering stiffness over the static axle load [1/rad] (equal on the type path).
    mu_y : ndarray
        Peak lateral friction at the static load [-].
    lateral_source : str
        One of :data:`LATERAL_SOURCES`.
    mu_y_source : str
        One of :data:`MU_Y_SOURCES`.
    surface : str
        The surface μ_y belongs to: the drive's, or :data:`TYPE_SURFACE`.
    note : str
        Why this source (e.g. the reason a fit has no lateral posterior); "" when nothing to say.

    Examples
    --------
    >>> c = np.array([14.0, 15.0, 16.0])
    >>> x = VmaxInputs(c, c, np.array([0.9, 0.95, 1.0]), "type_prior", "type_prior", TYPE_SURFACE)
    >>> x.n_draws, round(x.to_dict()["mu_y"]["mean"], 3)
    (3, 0.95)
    >>> VmaxInputs(c, c, c, "guess", "type_prior", TYPE_SURFACE)
    Traceback (most recent call last):
    ...
    ValueError: lateral_source: expected one of (...), got 'guess'
    """

    c_y_front: np.ndarray
    c_y_rear: np.ndarray
    mu_y: np.ndarray
    lateral_source: str
    mu_y_source: str
    surface: str
    note: str = ""

    def __post_init__(self) -> None:
        if self.lateral_source not in LATERAL_SOURCES:
            raise ValueError(
                f"lateral_source: expected one of {LATERAL_SOURCES}, got {self.lateral_source!r}"
            )
        if self.mu_y_source not in MU_Y_SOURCES:
            raise ValueError(
                f"mu_y_source: expected one of {MU_Y_SOURCES}, got {self.mu_y_source!r}"
            )
        shapes = {np.shape(self.c_y_front), np.shape(self.c_y_rear), np.shape(self.mu_y)}
        if len(shapes) != 1 or len(next(iter(shapes))) != 1:
            raise ValueError(f"VmaxInputs: expected draws of one shape (n,), got {sorted(shapes)}")

    @property
    def n_draws(self) -> int:
        return int(np.shape(self.mu_y)[0])

    def to_dict(self) -> dict:
        """Sources, surface, note and ``{"mean", "sd", "hdi_90"}`` of each parameter."""
        return {
            "lateral_source": self.lateral_source,
            "mu_y_source": self.mu_y_source,
            "surface": self.surface,
            "note": self.note,
            "c_y_front": summarize(self.c_y_front).to_dict(),
            "c_y_rear": summarize(self.c_y_rear).to_dict(),
            "mu_y": summarize(self.mu_y).to_dict(),
            "n_draws": self.n_draws,
        }
