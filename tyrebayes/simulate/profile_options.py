"""What a simulated drive's profile is made of: the segment labels, the driver's options
(:class:`ProfileOptions`) and the planned profile (:class:`DriveProfile`).

:func:`~tyrebayes.simulate.profiles.make_profile` plans one; re-exported by
:mod:`tyrebayes.simulate.profiles`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Longitudinal segment labels (index = code in :attr:`DriveProfile.long_label`).
LONG_LABELS: tuple[str, ...] = (
    "stop",
    "cruise",
    "accelerate",
    "decelerate",
    "hard_brake",
    "abs",
    "recovery",
)


#: Lateral segment labels (index = code in :attr:`DriveProfile.lat_label`).
LAT_LABELS: tuple[str, ...] = ("straight", "corner", "lane_change")


#: Tightest curve radius the driver takes [m] (urban junctions).
MIN_CURVE_RADIUS_M = 15.0


_L = {name: i for i, name in enumerate(LONG_LABELS)}


_Y = {name: i for i, name in enumerate(LAT_LABELS)}


@dataclass(frozen=True)
class ProfileOptions:
    """How the simulated driver drives (all numbers are per drive, not per tyre).

    Parameters
    ----------
    cruise_speeds_kmh : tuple of float
        Cruise speeds the driver picks from (urban, rural, motorway) [km/h].
    cruise_weights : tuple of float
        Relative frequency of each cruise speed.
    mean_cruise_s : float
        Mean duration of a cruise segment [s] (exponential, clipped to 5–180 s).
    accel_range_mps2 : tuple of float
        Range of peak accelerations of ordinary speed changes [m/s²]; limited by the surface.
    stop_probability : float
        Probability that a speed change ends in a standstill (urban stops).
    stop_duration_s : tuple of float
        Range of standstill durations [s].
    speed_wander_mps : float
        Standard deviation of the speed wander while cruising [m/s] (Ornstein–Uhlenbeck, 8 s).
    hard_brakes_per_hour, abs_events_per_hour : float
        Rates of hard (non-ABS) braking and of ABS full braking. ``n_abs_events`` overrides the
        ABS rate with an exact count spread over the drive.
    n_abs_events : int
        Exact number of ABS events (``-1``: use the rate).
    abs_duration_s : tuple of float
        Range of ABS braking durations [s].
    corners_per_hour, lane_changes_per_hour : float
        Rates of corners (trapezoidal a_y) and lane changes (one sine period of a_y).
    corner_ay_mps2, lane_change_ay_mps2 : tuple of float
        Ranges of their lateral accelerations [m/s²]; limited to 0.5 μ g by the surface.
    grade_sd_rad : float
        Standard deviation of the road grade [rad] (OU process, 40 s correlation time).
    initial_speed_kmh : float
        Speed at t = 0 [km/h].
    """

    cruise_speeds_kmh: tuple[float, ...] = (30.0, 50.0, 70.0, 90.0, 110.0)
    cruise_weights: tuple[float, ...] = (1.0, 2.0, 2.0, 2.0, 2.0)
    mean_cruise_s: float = 40.0
    accel_range_mps2: tuple[float, float] = (0.4, 2.0)
    stop_probability: float = 0.1
    stop_duration_s: tuple[float, float] = (3.0, 20.0)
    speed_wander_mps: float = 0.5
    hard_brakes_per_hour: float = 6.0
    abs_events_per_hour: float = 0.0
    n_abs_events: int = -1
    abs_duration_s: tuple[float, float] = (1.5, 2.5)
    corners_per_hour: float = 60.0
    lane_changes_per_hour: float = 30.0
    corner_ay_mps2: tuple[float, float] = (1.0, 4.0)
    lane_change_ay_mps2: tuple[float, float] = (0.5, 2.0)
    grade_sd_rad: float = 0.02
    initial_speed_kmh: float = 50.0

    def __post_init__(self):
        if len(self.cruise_speeds_kmh) != len(self.cruise_weights) or not self.cruise_speeds_kmh:
            raise ValueError(
                "ProfileOptions.cruise_weights: expected one weight per cruise speed, got "
                f"{len(self.cruise_weights)} for {len(self.cruise_speeds_kmh)} speeds"
            )
        if min(self.cruise_speeds_kmh) <= 5.0:
            raise ValueError(
                f"ProfileOptions.cruise_speeds_kmh: expected speeds > 5 km/h, got "
                f"{self.cruise_speeds_kmh}"
            )
        for name in ("mean_cruise_s", "initial_speed_kmh"):
            if not getattr(self, name) > 0:
                raise ValueError(f"ProfileOptions.{name}: expected > 0, got {getattr(self, name)}")
        for name in (
            "speed_wander_mps",
            "hard_brakes_per_hour",
            "abs_events_per_hour",
            "corners_per_hour",
            "lane_changes_per_hour",
            "grade_sd_rad",
        ):
            if not getattr(self, name) >= 0:
                raise ValueError(f"ProfileOptions.{name}: expected >= 0, got {getattr(self, name)}")
        if not 0.0 <= self.stop_probability <= 1.0:
            raise ValueError(
                f"ProfileOptions.stop_probability: expected a value in [0, 1], got "
                f"{self.stop_probability}"
            )
        lo, hi = self.accel_range_mps2
        if not 0 < lo <= hi:
            raise ValueError(
                "ProfileOptions.accel_range_mps2: expected 0 < lo <= hi, got "
                f"{self.accel_range_mps2}"
            )


@dataclass(frozen=True)
class AbsEvent:
    """Sample ranges of one ABS event and of the recovery segment that follows it."""

    start: int
    stop: int
    recovery_stop: int


@dataclass(frozen=True)
class DriveProfile:
    """Planned kinematics on a uniform time grid (NumPy arrays of length n).

    Attributes
    ----------
    time_s : time [s] from 0.
    speed_mps : planned longitudinal speed V_x [m/s] (≥ 0).
    accel_mps2 : dV_x/dt [m/s²] (the planned value; ABS samples are replaced by the drive).
    ay_mps2 : lateral acceleration a_y [m/s²], positive turning left.
    grade_rad : road grade θ [rad], positive uphill.
    long_label, lat_label : int8 codes into :data:`LONG_LABELS`, :data:`LAT_LABELS`.
    abs_events : the ABS events (sample ranges).
    """

    time_s: np.ndarray
    speed_mps: np.ndarray
    accel_mps2: np.ndarray
    ay_mps2: np.ndarray
    grade_rad: np.ndarray
    long_label: np.ndarray
    lat_label: np.ndarray
    abs_events: tuple[AbsEvent, ...] = field(default_factory=tuple)

    @property
    def dt_s(self) -> float:
        """Sample interval [s]."""
        return float(self.time_s[1] - self.time_s[0])
