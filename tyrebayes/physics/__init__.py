"""Tyre, vehicle, temperature, wear and lane-change physics: pure JAX, no files.

The public names are listed in ``__all__``: those :mod:`tyrebayes` re-exports, and the
further models and constants a benchmark or a user reproducing the thesis needs. Import them from
here, not from the modules under this package. Each is imported on first use (PEP 562), so that
``tyrebayes.physics.vehicle`` (which reading a vehicle file needs) loads without the rest.

* vehicle: :class:`Vehicle`, :data:`GRAVITY_MPS2`;
* tyre curves: :func:`brush_longitudinal`, :class:`BrushTyre`, :class:`MagicFormulaLongitudinal`;
* temperature: :class:`ThermalParams`, :func:`convective_conductance`,
  :func:`rolling_loss_power`, :func:`stiffness_with_sensitivity`,
  :func:`stiffness_at_temperature`, :class:`StiffnessTemperature`, :func:`compensate_stiffness`;
* wear: :class:`Abrasability`, :class:`TreadGeometry`, :class:`DriveWork`,
  :func:`simulate_constant_traction`, :func:`steady_constant_traction`,
  :func:`relative_wear_difference`, :func:`volume_to_mass_g`, :func:`relative_wear`,
  :func:`wear_integral`;
* lane change (ISO 3888-2): :func:`iso3888_2_course`, :func:`critical_speed`,
  :func:`critical_speed_sensitivity`, :class:`Tyres`, :class:`AxleTyres`, :class:`Driver`.

Examples
--------
>>> from tyrebayes.physics import GRAVITY_MPS2
>>> GRAVITY_MPS2
9.80665
"""

from ..internal.lazy_exports import lazy_exports as _lazy_exports

# Public name → the module under this package that holds it.
_EXPORTS = {
    "Vehicle": ".vehicle",
    "GRAVITY_MPS2": ".vehicle",
    "brush_longitudinal": ".tyre",
    "BrushTyre": ".tyre",
    "MagicFormulaLongitudinal": ".tyre",
    "ThermalParams": ".thermal",
    "convective_conductance": ".thermal",
    "rolling_loss_power": ".thermal",
    "stiffness_with_sensitivity": ".thermal",
    "stiffness_at_temperature": ".thermal",
    "StiffnessTemperature": ".thermal",
    "compensate_stiffness": ".thermal",
    "Abrasability": ".wear",
    "TreadGeometry": ".wear",
    "DriveWork": ".wear",
    "simulate_constant_traction": ".wear",
    "steady_constant_traction": ".wear",
    "relative_wear_difference": ".wear",
    "volume_to_mass_g": ".wear",
    "relative_wear": ".wear",
    "wear_integral": ".wear",
    "iso3888_2_course": ".lanechange",
    "critical_speed": ".lanechange",
    "critical_speed_sensitivity": ".lanechange",
    "Tyres": ".lanechange",
    "AxleTyres": ".lanechange",
    "Driver": ".lanechange",
}

__all__ = list(_EXPORTS)


__getattr__, __dir__ = _lazy_exports(__name__, _EXPORTS, globals())
