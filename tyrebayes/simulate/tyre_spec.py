"""The true tyre of a simulated drive: compensated stiffness, friction per surface, curve shape.

Examples
--------
>>> spec = TyreSpec.from_type("winter")
>>> spec.c_xr
30.0
>>> round(spec.mu_on("snow"), 2)
0.45
"""

from __future__ import annotations

import equinox as eqx
import numpy as np

from .._domain import SURFACES
from .._tyre_curve_sets import distinct_passenger_sets
from ..physics.thermal import StiffnessTemperature
from ..physics.tyre import MagicFormulaLongitudinal

#: Typical tyres per type: (C_xr, C_y [1/rad], μ on dry, wet, snow, ice). μ sits ~5-10 % above the
#: mean ABS decelerations of ``tyrebayes/data/braking_by_tyre_type.csv`` (snow: winter 0.34-0.45 g,
#: summer < 0.18 g; ice 0.12-0.15 g vs 0.08 g; wet 0.71-0.85 g; dry 0.90-1.11 g), the same
#: numbers as the fleet generator's type medians; C_xr as in thesis Fig. 6.1 (winter soft).
TYPICAL_TYRES: dict[str, tuple[float, float, float, float, float, float]] = {
    "winter": (30.0, 16.0, 0.95, 0.78, 0.45, 0.15),
    "all_season": (40.0, 18.0, 1.05, 0.80, 0.42, 0.13),
    "summer": (55.0, 22.0, 1.15, 0.85, 0.18, 0.09),
}
TYRE_MODELS: tuple[str, ...] = ("brush", "magic_formula")


class TyreSpec(eqx.Module):
    """Truth parameters of one tyre set (all four tyres alike).

    Parameters
    ----------
    c_xr : float
        Longitudinal slip stiffness compensated to 20 °C, C_xr [-] (thesis Sec. 3.3.1).
    mu_dry, mu_wet, mu_snow, mu_ice : float
        Friction potential μ_max on each surface [-] (thesis eq. 3.3).
    c_y_per_rad : float
        Cornering stiffness C_y normalised by F_z [1/rad].
    mu_slide_ratio : float
        Sliding-to-peak friction ratio of the brush truth in (0, 1] (1: flat after the peak).
    stiffness_temperature : StiffnessTemperature
        How C_x follows tyre temperature (C_x(T) from C_xr).
    magic_formula : MagicFormulaLongitudinal
        The Magic Formula set whose shape (PCX1, PEX*, load dependence) the ``magic_formula``
        truth uses, scaled to C_x and μ: by default Pacejka's measured 205/60R15; one drawn from
        the shipped database with :func:`draw_database_curve`.
    """

    c_xr: float
    mu_dry: float
    mu_wet: float
    mu_snow: float
    mu_ice: float
    c_y_per_rad: float = 20.0
    mu_slide_ratio: float = 1.0
    stiffness_temperature: StiffnessTemperature = StiffnessTemperature()
    magic_formula: MagicFormulaLongitudinal = MagicFormulaLongitudinal.from_measured(
        "pacejka_205_60R15"
    )

    def __check_init__(self):
        for name in ("c_xr", "mu_dry", "mu_wet", "mu_snow", "mu_ice", "c_y_per_rad"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"TyreSpec.{name}: expected a finite value > 0, got {value!r}")
        if not 0.0 < self.mu_slide_ratio <= 1.0:
            raise ValueError(
                f"TyreSpec.mu_slide_ratio: expected a value in (0, 1], got {self.mu_slide_ratio!r}"
            )

    def mu_on(self, surface: str) -> float:
        """μ_max on ``surface`` (``dry``, ``wet``, ``snow``, ``ice``)."""
        if surface not in SURFACES:
            raise ValueError(f"surface: expected one of {SURFACES}, got {surface!r}")
        return float(getattr(self, f"mu_{surface}"))

    @classmethod
    def from_type(cls, tyre_type: str, c_xr: float | None = None, **kwargs) -> TyreSpec:
        """A typical tyre of ``tyre_type`` (``winter``, ``all_season``, ``summer``).

        Numbers from :data:`TYPICAL_TYRES`; ``c_xr`` and any field given in ``kwargs`` override.
        """
        if tyre_type not in TYPICAL_TYRES:
            raise ValueError(
                f"tyre_type: expected one of {sorted(TYPICAL_TYRES)}, got {tyre_type!r}"
            )
        c, c_y, *mus = TYPICAL_TYRES[tyre_type]
        fields = dict(zip(("mu_dry", "mu_wet", "mu_snow", "mu_ice"), mus, strict=True))
        fields.update(c_xr=c if c_xr is None else float(c_xr), c_y_per_rad=c_y)
        fields.update(kwargs)
        return cls(**fields)


def draw_database_curve(rng: np.random.Generator) -> MagicFormulaLongitudinal:
    """One of the distinct car/SUV Magic Formula sets of the shipped database, at random.

    Its shape C, traction-side curvature E and load dependences (PKX2-3, PDX2, PEX2-3) as the
    source file gives them; the simulator scales slope and peak to the drive's C_x and μ
    (:mod:`tyrebayes.simulate.tyre_curves`), so only the shape comes from the row.

    Examples
    --------
    >>> mf = draw_database_curve(np.random.default_rng(0))
    >>> 1.0 < mf.pcx1 < 2.0
    True
    """
    sets = distinct_passenger_sets()
    row = sets.iloc[int(rng.integers(len(sets)))]
    return MagicFormulaLongitudinal(
        fnomin_n=float(row["fnomin_n"]),
        pkx1=float(row["Kx_over_Fz"]),
        pdx1=float(row["mu_peak"]),
        pcx1=float(row["C"]),
        pex1=float(row["E_traction"]),
        pkx2=float(row["PKX2"]),
        pkx3=float(row["PKX3"]),
        pdx2=float(row["PDX2"]),
        pex2=float(row["PEX2"]),
        pex3=float(row["PEX3"]),
    )
