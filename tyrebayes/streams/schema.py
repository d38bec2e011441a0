"""The stream-file contract: column names, units and plausibility ranges.

One row per sample, SI units, column names after thesis Table 1.1 (see ``DESIGN.md``). Axes follow
ISO 8855 like :mod:`tyrebayes.physics.vehicle`: x forward, y left, z up; yaw rate and steering
positive to the left. NaN marks a dropped sample; extra columns are kept and ignored.

Examples
--------
>>> REQUIRED_COLUMNS[:2]
('time', 'wheel_speed_fl')
>>> CHANNELS["steering_wheel_angle"].unit
'rad'
"""

from __future__ import annotations

from dataclasses import dataclass

WHEEL_COLUMNS: tuple[str, str, str, str] = (
    "wheel_speed_fl",
    "wheel_speed_fr",
    "wheel_speed_rl",
    "wheel_speed_rr",
)
"""Wheel angular speeds in the fixed order (front-left, front-right, rear-left, rear-right)."""

REQUIRED_COLUMNS: tuple[str, ...] = (
    "time",
    *WHEEL_COLUMNS,
    "ax",
    "ay",
    "yaw_rate",
    "steering_wheel_angle",
)

OPTIONAL_COLUMNS: tuple[str, ...] = (
    "engine_speed",
    "wheel_angle_front",
    "wheel_angle_rear",
    "az",
    "ambient_temperature",
    "speed_reference",
)


@dataclass(frozen=True)
class ChannelSpec:
    """Unit and hard plausibility range of one channel.

    Values outside ``[lo, hi]`` cannot come from a road car in the stated unit; they are read as a
    unit mistake (or a broken sensor) and rejected, never clipped.

    Parameters
    ----------
    name : str
        Column name.
    unit : str
        SI unit of the column.
    lo, hi : float
        Plausible range in that unit.
    description : str
        What the channel is.
    """

    name: str
    unit: str
    lo: float
    hi: float
    description: str


# Ranges: wheel speeds up to 450 km/h on a 0.25 m wheel (500 rad/s), reverse allowed down to
# -50 rad/s; accelerations within ±30 m/s² (crash-free driving stays within ±15 m/s², IMU spikes
# over potholes reach ~2 g); yaw rate ±3 rad/s (a spin); steering-wheel angle ±4π rad (two turns
# each way exceeds every production rack, so a larger value is degrees); road-wheel angles ±1 rad.
CHANNELS: dict[str, ChannelSpec] = {
    spec.name: spec
    for spec in (
        ChannelSpec("time", "s", -1e12, 1e12, "sample time, strictly increasing"),
        ChannelSpec("wheel_speed_fl", "rad/s", -50.0, 500.0, "front-left wheel angular speed"),
        ChannelSpec("wheel_speed_fr", "rad/s", -50.0, 500.0, "front-right wheel angular speed"),
        ChannelSpec("wheel_speed_rl", "rad/s", -50.0, 500.0, "rear-left wheel angular speed"),
        ChannelSpec("wheel_speed_rr", "rad/s", -50.0, 500.0, "rear-right wheel angular speed"),
        ChannelSpec("ax", "m/s^2", -30.0, 30.0, "longitudinal IMU specific force"),
        ChannelSpec("ay", "m/s^2", -30.0, 30.0, "lateral IMU specific force, left positive"),
        ChannelSpec("yaw_rate", "rad/s", -3.0, 3.0, "yaw rate, left positive"),
        ChannelSpec(
            "steering_wheel_angle", "rad", -12.6, 12.6, "steering-wheel angle, left positive"
        ),
        ChannelSpec("engine_speed", "rad/s", -10.0, 1500.0, "engine speed"),
        ChannelSpec("wheel_angle_front", "rad", -1.0, 1.0, "front road-wheel angle"),
        ChannelSpec("wheel_angle_rear", "rad", -1.0, 1.0, "rear road-wheel angle"),
        ChannelSpec("az", "m/s^2", -40.0, 40.0, "vertical IMU specific force (+g at rest, z up)"),
        ChannelSpec("ambient_temperature", "degC", -60.0, 70.0, "ambient air temperature"),
        ChannelSpec("speed_reference", "m/s", -5.0, 130.0, "reference speed, e.g. GNSS"),
    )
}

# Minimum number of valid samples the pipeline needs: derivatives use 0.2-1 s windows and the
# nuisance estimates need several seconds of data; 100 samples is one second at 100 Hz.
MIN_SAMPLES = 100
