"""Sensor streams: file formats, validation, and the signal pipeline to tyre features."""

from .can import CarProfile as CarProfile
from .can import load_profile as load_profile
from .can import read_can_log as read_can_log
from .features import StreamFeatures as StreamFeatures
from .features import compute_features as compute_features
from .features import speed_error as speed_error
from .io import read_stream as read_stream
from .io import write_stream as write_stream
from .noise import quantisation_step as quantisation_step
from .noise import white_noise_sd as white_noise_sd
from .nuisances import ImuGainCorrection as ImuGainCorrection
from .nuisances import StreamNuisances as StreamNuisances
from .nuisances import estimate_ax_gain as estimate_ax_gain
from .nuisances import imu_gain_correction as imu_gain_correction
from .schema import OPTIONAL_COLUMNS as OPTIONAL_COLUMNS
from .schema import REQUIRED_COLUMNS as REQUIRED_COLUMNS
from .segments import SEGMENT_REGIMES as SEGMENT_REGIMES
from .segments import SegmentThresholds as SegmentThresholds
from .tyre_temperature import driven_tyre_temperature as driven_tyre_temperature
from .tyre_temperature import features_tyre_temperature as features_tyre_temperature
from .validate import ValidatedStream as ValidatedStream
from .validate import validate_stream as validate_stream
