"""Raw CAN logs in: frame readers, vectorised DBC decoding, car profiles, conversion to streams."""

from .comma import read_comma_raw_can as read_comma_raw_can
from .convert import CanConversion as CanConversion
from .convert import read_can_log as read_can_log
from .convert import validate_conversion as validate_conversion
from .dbc import SignalLayout as SignalLayout
from .dbc import decode_signal as decode_signal
from .dbc import load_dbc as load_dbc
from .frames import CAN_SUFFIXES as CAN_SUFFIXES
from .frames import CanFrames as CanFrames
from .frames import FrameCounts as FrameCounts
from .frames import read_frames as read_frames
from .profile import CarProfile as CarProfile
from .profile import ProfileChannel as ProfileChannel
from .profile import load_profile as load_profile
