"""Static view of :mod:`tyrebayes`'s public API: the names it re-exports, in task order.

``tyrebayes/__init__.py`` reads this file and imports each module on first use of one of its
names; type checkers and IDEs read it as the package's interface. Add a public name here.
"""

# ruff: noqa: I001
# 1. read and validate streams, vehicles, measured data
from ._domain import SURFACES as SURFACES
from ._domain import TYRE_TYPES as TYRE_TYPES
from ._domain import load_vehicle as load_vehicle
from ._errors import BadInputError as BadInputError
from .physics.vehicle import Vehicle as Vehicle
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
from .streams.wear_evidence import WEAR_EVIDENCE_COLUMNS as WEAR_EVIDENCE_COLUMNS
from .streams.cornering_stiffness import CorneringStiffness as CorneringStiffness
from .streams.wear_evidence import DriveWearEvidence as DriveWearEvidence
from .streams.wear_evidence import drive_wear_evidence as drive_wear_evidence
from .streams.wear_evidence_table import wear_evidence_table as wear_evidence_table

# 2. fit: observations, fitters, the one result type
from .inference.fleet import fit_fleet as fit_fleet
from .inference.fleet import load_tyre_type_priors as load_tyre_type_priors
from .inference.ols import fit_ols as fit_ols
from .inference.result import FIT_METHODS as FIT_METHODS
from .inference.result import POLICY as POLICY
from .inference.result import ConvergencePolicy as ConvergencePolicy
from .inference.result import Diagnostics as Diagnostics
from .inference.result import Fit as Fit
from .inference.result import Provenance as Provenance
from .inference.result import diagnose as diagnose
from .inference.result import load_fit as load_fit
from .inference.tyre.data import TyreObservations as TyreObservations
from .inference.tyre.data import WindowTable as WindowTable
from .inference.tyre.data import observations_from_features as observations_from_features
from .inference.tyre.data import observations_from_stream as observations_from_stream
from .inference.tyre.data import stack_drives as stack_drives
from .inference.tyre.data import windowed_observations as windowed_observations
from .inference.tyre.fit import TyreFit as TyreFit
from .inference.tyre.fit import fit_tyre as fit_tyre
from .inference.tyre.model import TyrePriors as TyrePriors
from .inference.tyre.predictive import with_pointwise as with_pointwise
from .inference.lateral import CorneringObservations as CorneringObservations
from .inference.lateral import NoCornering as NoCornering
from .inference.lateral import cornering_observations as cornering_observations
from .inference.lateral import LateralPriors as LateralPriors
from .inference.lateral import fit_lateral as fit_lateral
from .inference.lateral import LateralFit as LateralFit
from .inference.wear import build_wear_data as build_wear_data
from .inference.wear import fit_wear as fit_wear
from .inference.wear.history import drive_history as drive_history
from .inference.wear.history import tread_readings as tread_readings
from .inference.wear.changepoint import detect_tyre_changes as detect_tyre_changes
from .inference.wear.history_fit import fit_wear_history as fit_wear_history
from .inference.wear.cornering import (
    cornering_stiffness_from_lateral as cornering_stiffness_from_lateral,
)
from .inference.wear.cornering import (
    cornering_stiffness_from_drives as cornering_stiffness_from_drives,
)
from .inference.wear.cornering import DrivesCornering as DrivesCornering
from .inference.online import OnlineConfig as OnlineConfig
from .inference.online import OnlineEstimator as OnlineEstimator
from .inference.online import online_estimate as online_estimate
from .inference.online import OnlineRun as OnlineRun
from .inference.online import OnlineSummary as OnlineSummary
from .inference.online import stream_steps as stream_steps
from .inference.online import stream_windows as stream_windows
from .inference.online import window_blocks as window_blocks
from .inference.online import OnlineLateral as OnlineLateral
from .inference.online import online_lateral as online_lateral
from .inference.online import LateralRun as LateralRun
from .inference.online import lateral_blocks as lateral_blocks

# 3. predict
from .inference.fleet import predict_friction as predict_friction
from .inference.fleet import lateral_ratio_draws as lateral_ratio_draws
from .inference.summary import summarize as summarize
from .inference.summary import PosteriorSummary as PosteriorSummary
from .inference.vmax.inputs import VmaxInputs as VmaxInputs
from .inference.vmax.prediction import VmaxPrediction as VmaxPrediction
from .inference.vmax.fit_inputs import fit_vmax_inputs as fit_vmax_inputs
from .inference.vmax.fleet_ratio import fleet_ratio_vmax_inputs as fleet_ratio_vmax_inputs
from .inference.vmax.lateral import lateral_vmax_inputs as lateral_vmax_inputs
from .inference.vmax.prediction import predict_vmax as predict_vmax
from .inference.vmax.type_relations import type_vmax_inputs as type_vmax_inputs
from .inference.vmax.prediction import vmax_draws as vmax_draws
from .inference.wear import predict_wear_volume as predict_wear_volume
from .inference.wear.history_predict import WearHistoryPrediction as WearHistoryPrediction
from .inference.wear.history_predict import wear_history_predictions as wear_history_predictions
from .physics.lanechange import critical_speed as critical_speed
from .physics.lanechange import iso3888_2_course as iso3888_2_course
from .physics.thermal import StiffnessTemperature as StiffnessTemperature
from .physics.thermal import compensate_stiffness as compensate_stiffness
from .physics.thermal import stiffness_at_temperature as stiffness_at_temperature
from .physics.tyre import BrushTyre as BrushTyre
from .physics.tyre import MagicFormulaLongitudinal as MagicFormulaLongitudinal
from .physics.tyre import brush_longitudinal as brush_longitudinal
from .physics.wear import relative_wear as relative_wear
from .physics.wear import wear_integral as wear_integral

# 4. decide
from .decisions import cost_threshold as cost_threshold
from .decisions import derive_mu_min_snow as derive_mu_min_snow
from .decisions import high_wear_warning as high_wear_warning
from .decisions import winter_verdict as winter_verdict
from .decisions import WearWarning as WearWarning
from .decisions import WinterVerdict as WinterVerdict

# 5. criticise
from .criticism import CandidateResult as CandidateResult
from .criticism import CriticismResult as CriticismResult
from .criticism import criticize_fleet_fit as criticize_fleet_fit
from .criticism import criticize_stream as criticize_stream
from .criticism import criticize_table as criticize_table
from .criticism import criticize_tyre_fit as criticize_tyre_fit
from .criticism import posterior_predictive_check as posterior_predictive_check
from .criticism import PredictiveChecks as PredictiveChecks
from .criticism import StatisticCheck as StatisticCheck

# 6. report
from .report import Report as Report
from .report import write_report as write_report
from .report import ReportFiles as ReportFiles

# 7. fleet runs on dask.distributed
from .batch import RunSettings as RunSettings
from .batch import dask_client as dask_client
from .batch import fleet_run as fleet_run
from .batch import FleetRunResult as FleetRunResult
from .batch import read_manifest as read_manifest
