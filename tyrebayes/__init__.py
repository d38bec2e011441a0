"""tyrebayes: tyre parameters with honest uncertainty from the sensors every car already has.

The public API, re-exported from the modules that define it. Data flows one way:
file → :mod:`tyrebayes.streams` → :mod:`tyrebayes.inference` (using :mod:`tyrebayes.physics`)
→ predictions → :mod:`tyrebayes.decisions`; :mod:`tyrebayes.criticism` reads fits and data.
"""

from ._errors import BadInputError as BadInputError
from .criticism import criticize_stream as criticize_stream
from .criticism import criticize_table as criticize_table
from .criticism import posterior_predictive_check as posterior_predictive_check
from .decisions import cost_threshold as cost_threshold
from .decisions import derive_mu_min_snow as derive_mu_min_snow
from .decisions import winter_verdict as winter_verdict
from .inference.fleet import fit_fleet as fit_fleet
from .inference.fleet import load_tyre_type_priors as load_tyre_type_priors
from .inference.fleet import predict_friction as predict_friction
from .inference.ols import fit_ols as fit_ols
from .inference.summary import summarize as summarize
from .inference.tyre_data import TyreObservations as TyreObservations
from .inference.tyre_data import observations_from_features as observations_from_features
from .inference.tyre_data import observations_from_stream as observations_from_stream
from .inference.tyre_data import stack_drives as stack_drives
from .inference.tyre_data import windowed_observations as windowed_observations
from .inference.tyre_fit import FitDiagnostics as FitDiagnostics
from .inference.tyre_fit import TyreFit as TyreFit
from .inference.tyre_fit import fit_tyre as fit_tyre
from .inference.tyre_model import TyrePriors as TyrePriors
from .inference.vmax import vmax_draws as vmax_draws
from .inference.wear import fit_wear as fit_wear
from .inference.wear import high_wear_warning as high_wear_warning
from .inference.wear import predict_wear_volume as predict_wear_volume
from .physics.lanechange import critical_speed as critical_speed
from .physics.lanechange import iso3888_2_course as iso3888_2_course
from .physics.thermal import StiffnessTemperature as StiffnessTemperature
from .physics.thermal import compensate_stiffness as compensate_stiffness
from .physics.thermal import stiffness_at_temperature as stiffness_at_temperature
from .physics.tyre import BrushTyre as BrushTyre
from .physics.tyre import MagicFormulaLongitudinal as MagicFormulaLongitudinal
from .physics.tyre import brush_longitudinal as brush_longitudinal
from .physics.vehicle import Vehicle as Vehicle
from .physics.vehicle import load_vehicle as load_vehicle
from .physics.wear import relative_wear as relative_wear
from .physics.wear import wear_integral as wear_integral
from .simulate.drive import simulate_drive as simulate_drive
from .simulate.fleet import simulate_fleet as simulate_fleet
from .simulate.vehicle_truth import ThermalSpread as ThermalSpread
from .simulate.vehicle_truth import VehicleSpread as VehicleSpread
from .simulate.vehicle_truth import draw_true_thermal as draw_true_thermal
from .simulate.vehicle_truth import draw_true_vehicle as draw_true_vehicle
from .streams.can.convert import read_can_log as read_can_log
from .streams.can.profile import load_profile as load_profile
from .streams.features import StreamFeatures as StreamFeatures
from .streams.features import compute_features as compute_features
from .streams.io import read_stream as read_stream
from .streams.io import write_stream as write_stream
from .streams.tyre_temperature import driven_tyre_temperature as driven_tyre_temperature
from .streams.tyre_temperature import features_tyre_temperature as features_tyre_temperature
from .streams.validate import ValidatedStream as ValidatedStream
from .streams.validate import validate_stream as validate_stream

__version__ = "0.1.0"
