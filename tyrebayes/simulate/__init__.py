"""Simulated drives, fleets and wear with known truth: the data of the tests, benchmarks and demo.

Not part of ``import tyrebayes`` (the library never needs a simulator): a benchmark or a user who
wants data with known truth imports the names below from here (``__all__``), never from the
modules under this package. Each name is imported on first use (PEP 562), so that importing one
simulator does not load the others.

* drives: :func:`simulate_drive` (a longitudinal drive log with its truth; the curve of a seed:
  :func:`drawn_curve`), :class:`ProfileOptions` and :func:`profile_from_trace` (its speed
  profile), :class:`SensorModel` and :func:`scale_noise` (its sensors), :func:`write_drive` (a
  drive's stream and truth files), :func:`simulate_cornering` (a cornering drive),
  :func:`synthetic_stream` (a kinematic test signal with closed-form truth), and
  :func:`stream_messages` (a drive as CAN frames);
* tyres and cars: :class:`TyreSpec` and :func:`draw_database_curve` (a tyre's curve),
  :class:`VehicleSpread`, :class:`ThermalSpread`, :func:`draw_true_vehicle`,
  :func:`draw_true_thermal` and :func:`force_gain` (a car's true parameters and their spread),
  :func:`simulate_tyre_set_drives` (the drives of one tyre set);
* fleets: :func:`simulate_fleet` (a fleet table; :data:`THESIS_AGED_TYRE_EFFECT`);
* wear: :class:`DutyProfile`, :func:`simulate_drives`, :func:`profile_kernel`,
  :func:`seasonal_ambient` and :func:`observe_wear` (drives and tread readings of a tyre set),
  :func:`simulate_wear_year` (one car's year of drives and readings).

Examples
--------
>>> from tyrebayes.simulate import simulate_fleet
>>> simulate_fleet.__module__
'tyrebayes.simulate.fleet'
>>> import tyrebayes.simulate
>>> "simulate_drive" in tyrebayes.simulate.__all__
True
"""

from ..internal.lazy_exports import lazy_exports as _lazy_exports

# Public name → the module (under this package, or the package's) that holds it.
_EXPORTS = {
    "simulate_drive": ".drive",
    "drawn_curve": ".drive",
    "ProfileOptions": ".profiles",
    "profile_from_trace": ".profiles",
    "SensorModel": ".sensors",
    "scale_noise": ".sensors",
    "write_drive": ".drive_io",
    "simulate_cornering": ".cornering",
    "synthetic_stream": "tyrebayes.streams.synthetic",
    "stream_messages": ".can_log",
    "TyreSpec": ".tyre_spec",
    "draw_database_curve": ".tyre_spec",
    "VehicleSpread": ".vehicle_truth",
    "ThermalSpread": ".vehicle_truth",
    "draw_true_vehicle": ".vehicle_truth",
    "draw_true_thermal": ".vehicle_truth",
    "force_gain": ".vehicle_truth",
    "simulate_tyre_set_drives": ".tyre_set",
    "simulate_fleet": ".fleet",
    "THESIS_AGED_TYRE_EFFECT": ".fleet",
    "DutyProfile": ".wear",
    "simulate_drives": ".wear",
    "profile_kernel": ".wear",
    "seasonal_ambient": ".wear",
    "observe_wear": ".wear",
    "simulate_wear_year": ".wear_history",
}

__all__ = list(_EXPORTS)


__getattr__, __dir__ = _lazy_exports(__name__, _EXPORTS, globals())
