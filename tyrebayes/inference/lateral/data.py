"""Cornering observations: the signals a lateral fit reads, filtered, decimated and checked.

A drive's lateral evidence is its speed V_x, yaw rate r, lateral acceleration a_y and steering
angle (the steering-wheel angle, or a measured road-wheel angle where a log has one). They are
low-passed (zero-phase, :data:`LOWPASS_HZ`), the yaw acceleration ṙ is differentiated from the
smoothed yaw rate, and everything is decimated to :data:`RATE_HZ`: the single-track dynamics live
below 2 Hz, and above it the samples carry only noise that would be counted as information.

:func:`cornering_observations` returns :class:`CorneringObservations`, or raises
:class:`NoCornering` with a one-line reason when the drive has too little cornering to identify
anything (the command prints ``"lateral": null`` with it).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pandas as pd
from jaxtyping import Array, Bool, Float
from scipy.signal import butter, sosfiltfilt

from ...internal.device_arrays import device_array
from ...physics.vehicle import Vehicle
from ...streams.order_stats import median

#: Zero-phase low-pass cut-off of every channel [Hz].
LOWPASS_HZ = 2.0
#: Rate of the decimated observations [Hz].
RATE_HZ = 10.0
#: Samples below this speed are left out: L·r/V_x and the slip angles divide by it [m/s].
MIN_SPEED_MPS = 3.0
#: Samples whose |a_x| (the derivative of the low-passed V_x) exceeds this are left out of both
#: equations [m/s²]: the model normalises the axle forces by the *static* axle loads, and braking
#: or accelerating moves load between the axles (ΔF_z,f/F_z,f ≈ (a_x/g)(h/l_r), about 4 % at
#: 1 m/s²) and uses part of each tyre's friction for F_x. Kept, a corner taken braking reads the
#: front axle stiff, the rear soft and the understeer gradient low. Race-pace driving corners
#: mostly braking or accelerating and keeps little (the lateral guide says what that does).
MAX_LONGITUDINAL_MPS2 = 1.0
#: Cornering counts where |a_y| exceeds this at or above :data:`CORNERING_SPEED_MPS` [m/s²].
CORNERING_AY_MPS2 = 1.0
#: Speed above which a corner loads the tyres enough to show their stiffness [m/s].
CORNERING_SPEED_MPS = 8.0
#: Seconds of such cornering a drive needs before a lateral fit is attempted [s].
MIN_CORNERING_S = 15.0
G = 9.80665


class NoCornering(ValueError):
    """A drive without the cornering a lateral fit needs; the message is the one-line reason.

    Examples
    --------
    >>> issubclass(NoCornering, ValueError)
    True
    >>> try:
    ...     raise NoCornering("lateral: no usable cornering")
    ... except ValueError as err:
    ...     print(err)
    lateral: no usable cornering
    """


class CorneringObservations(eqx.Module):
    """Decimated cornering signals of one drive and the vehicle constants the model needs.

    Attributes
    ----------
    speed : Float[Array, "n"]
        Longitudinal speed V_x [m/s].
    yaw_rate : Float[Array, "n"]
        r [rad/s], ISO 8855 (positive turning left).
    yaw_acceleration : Float[Array, "n"]
        ṙ from the smoothed yaw rate [rad/s²].
    ay : Float[Array, "n"]
        Measured lateral acceleration [m/s²] (body-fixed sensor: roll and offset included).
    steering : Float[Array, "n"]
        Steering-wheel angle [rad], or the road-wheel angle where ``road_wheel`` is True.
    mask : Bool[Array, "n"]
        Samples that enter the steering equation (speed above :data:`MIN_SPEED_MPS`, finite,
        |a_x| at most :data:`MAX_LONGITUDINAL_MPS2`).
    mask_kinematic : Bool[Array, "n"]
        Samples that enter the lateral-kinematics equation (``mask``, and two neighbours each
        side with finite signals: it differentiates V_x·α_r).
    longitudinal : Bool[Array, "n"]
        Samples left out of both equations for |a_x| > :data:`MAX_LONGITUDINAL_MPS2` (braking or
        accelerating); their signals are kept, as neighbours of the derivatives.
    ax : Float[Array, "n"]
        a_x, the derivative of the low-passed V_x [m/s²] (what ``longitudinal`` is decided on;
        0 where a sample is not valid).
    dt_s : Array
        Sample interval [s] (0-d: a real clock's differs from drive to drive in the fourth
        digit, and a static value would compile every program once per drive).
    road_wheel : bool
        Whether ``steering`` is a road-wheel angle (no steering ratio to infer).
    mass_kg, wheelbase_m, cog_to_front_axle_m, yaw_inertia_kgm2, steering_ratio : Array
        The vehicle file's values (0-d arrays: one compiled fit serves every car); the yaw
        inertia and the steering ratio are priors' centres.
    cornering_seconds : Array
        Time spent above :data:`CORNERING_AY_MPS2` and :data:`CORNERING_SPEED_MPS` [s].

    Examples
    --------
    A steady 30 s circle at 15 m/s and 3 m/s² (:func:`cornering_observations` builds it):

    >>> from tyrebayes import load_vehicle
    >>> t = np.arange(0, 30, 0.01)
    >>> f = pd.DataFrame({"time": t, "yaw_rate": 0.2 + 0 * t, "ay": 3.0 + 0 * t,
    ...                   "speed_reference": 15 + 0 * t, "steering_wheel_angle": 0.5 + 0 * t})
    >>> obs = cornering_observations(f, load_vehicle("compact_fwd"))
    >>> obs.speed.shape, round(float(obs.cornering_seconds)), obs.road_wheel
    ((300,), 30, False)
    """

    speed: Float[Array, " n"]
    yaw_rate: Float[Array, " n"]
    yaw_acceleration: Float[Array, " n"]
    ay: Float[Array, " n"]
    steering: Float[Array, " n"]
    mask: Bool[Array, " n"]
    mask_kinematic: Bool[Array, " n"]
    longitudinal: Bool[Array, " n"]
    ax: Float[Array, " n"]
    dt_s: Float[Array, ""] = eqx.field(converter=jnp.asarray)
    road_wheel: bool = eqx.field(static=True)
    mass_kg: Float[Array, ""]
    wheelbase_m: Float[Array, ""]
    cog_to_front_axle_m: Float[Array, ""]
    yaw_inertia_kgm2: Float[Array, ""]
    steering_ratio: Float[Array, ""]
    cornering_seconds: Float[Array, ""]

    def __check_init__(self):
        n = self.speed.shape[0]
        for name in (
            "yaw_rate", "yaw_acceleration", "ay", "steering", "mask", "mask_kinematic",
            "longitudinal", "ax",
        ):  # fmt: skip
            if getattr(self, name).shape != (n,):
                raise ValueError(
                    f"CorneringObservations.{name}: expected shape ({n},), "
                    f"got {getattr(self, name).shape}"
                )

    @property
    def cog_to_rear_axle_m(self) -> Float[Array, ""]:
        return self.wheelbase_m - self.cog_to_front_axle_m

    @property
    def n_used(self) -> int:
        return int(np.asarray(self.mask).sum())

    @property
    def duration_s(self) -> float:
        """Length of the decimated record [s]."""
        return float(self.speed.shape[0] * self.dt_s)


def _speed(frame: pd.DataFrame, vehicle: Vehicle) -> np.ndarray:
    """V_x: the rear wheels' mean times the nominal radius, else ``speed_reference``/``speed``.

    The rear wheels are not steered: their mean is the rear axle's speed along the car, which
    is V_x, while the steered front wheels roll faster in a tight turn (by 1/cos δ, 2 % at
    δ = 0.2 rad), enough to bias the steering ratio found from low-speed turns. The mean of
    left and right cancels the track's inner/outer difference; the wheels' slip (a fraction of
    a percent) is far below what the lateral model is sensitive to.
    """
    wheels = ["wheel_speed_rl", "wheel_speed_rr"]
    if all(w in frame for w in wheels):
        return frame[wheels].to_numpy(float).mean(axis=1) * float(vehicle.wheel_radius_m)
    for name in ("speed_reference", "speed"):
        if name in frame:
            return frame[name].to_numpy(float)
    raise NoCornering(
        "lateral: expected wheel speeds or a speed_reference column for V_x, got neither"
    )


def _steering(frame: pd.DataFrame) -> tuple[np.ndarray, bool]:
    if "steering_wheel_angle" in frame and np.isfinite(frame["steering_wheel_angle"]).any():
        return frame["steering_wheel_angle"].to_numpy(float), False
    if "wheel_angle_front" in frame and np.isfinite(frame["wheel_angle_front"]).any():
        return frame["wheel_angle_front"].to_numpy(float), True
    raise NoCornering(
        "lateral: expected a steering_wheel_angle or wheel_angle_front column, got neither"
    )


def _lowpass(x: np.ndarray, rate_hz: float) -> np.ndarray:
    """Zero-phase second-order Butterworth at :data:`LOWPASS_HZ`, across NaN gaps by filling."""
    finite = np.isfinite(x)
    if not finite.any():
        return x
    idx = np.arange(x.size)
    filled = np.interp(idx, idx[finite], x[finite])
    cutoff = min(LOWPASS_HZ, 0.45 * rate_hz)
    sos = butter(2, cutoff / (rate_hz / 2.0), output="sos")
    out = sosfiltfilt(sos, filled)
    out[~finite] = np.nan
    return out


def _rate(x: np.ndarray, dt: float) -> np.ndarray:
    """dx/dt, across NaN gaps by interpolation (a gap is no braking)."""
    finite = np.isfinite(x)
    if x.size < 2 or finite.sum() < 2:
        return np.zeros(x.size)
    idx = np.arange(x.size)
    return np.gradient(np.interp(idx, idx[finite], x[finite]), dt)


def cornering_observations(frame: pd.DataFrame, vehicle: Vehicle) -> CorneringObservations:
    """The cornering observations of a stream (validated, on a uniform time base).

    Parameters
    ----------
    frame : pandas.DataFrame
        ``time`` [s], ``yaw_rate`` [rad/s], ``ay`` [m/s²], a speed (wheel speeds [rad/s] or
        ``speed_reference`` [m/s]) and a steering angle (``steering_wheel_angle`` or
        ``wheel_angle_front`` [rad]); ISO 8855 signs (the stream contract).
    vehicle : Vehicle

    Returns
    -------
    CorneringObservations

    Raises
    ------
    NoCornering
        A missing channel, or less than :data:`MIN_CORNERING_S` of cornering; the message is
        the reason in one line.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from tyrebayes import load_vehicle
    >>> t = np.arange(0, 60, 0.01)
    >>> f = pd.DataFrame({"time": t, "yaw_rate": 0.0 * t, "ay": 0.0 * t,
    ...                   "speed_reference": 20 + 0 * t, "steering_wheel_angle": 0 * t})
    >>> try:
    ...     cornering_observations(f, load_vehicle("compact_fwd"))
    ... except NoCornering as err:
    ...     print(err)
    lateral: no usable cornering: 0.0 s with |a_y| > 1 m/s² above 8 m/s (need 15 s)
    """
    for name in ("time", "yaw_rate", "ay"):
        if name not in frame:
            raise NoCornering(f"lateral: expected a {name} column, got none")
    time = frame["time"].to_numpy(float)
    if time.size < 4 or not np.all(np.diff(time) > 0):
        raise NoCornering("lateral: expected a strictly increasing time column of ≥ 4 samples")
    rate = 1.0 / median(np.diff(time), overwrite_input=True)  # np.median's, by one selection
    speed = _lowpass(_speed(frame, vehicle), rate)
    steering, road_wheel = _steering(frame)
    steering = _lowpass(steering, rate)
    yaw_rate = _lowpass(frame["yaw_rate"].to_numpy(float), rate)
    ay = _lowpass(frame["ay"].to_numpy(float), rate)
    yaw_acceleration = np.gradient(yaw_rate, time)
    step = max(1, int(round(rate / RATE_HZ)))
    keep = slice(0, None, step)
    speed, steering, yaw_rate, ay, yaw_acceleration = (
        x[keep] for x in (speed, steering, yaw_rate, ay, yaw_acceleration)
    )
    # The yaw acceleration's central differences reach one sample past a gap in the yaw rate.
    finite = np.isfinite(speed) & np.isfinite(steering) & np.isfinite(yaw_rate) & np.isfinite(ay)
    finite &= np.isfinite(yaw_acceleration)
    valid = finite & (np.nan_to_num(speed) > MIN_SPEED_MPS)
    dt = step / rate
    ax = _rate(speed, dt)
    longitudinal = valid & (np.abs(ax) > MAX_LONGITUDINAL_MPS2)
    mask = valid & ~longitudinal
    # The kinematic equation differentiates with a five-point stencil: both neighbours on
    # each side must carry finite signals (a braking neighbour's are kept for it).
    kinematic = mask.copy()
    for shift in (1, 2):
        kinematic[shift:] &= valid[:-shift]
        kinematic[:-shift] &= valid[shift:]
    kinematic[:2] = kinematic[-2:] = False
    cornering = mask & (np.abs(np.nan_to_num(ay)) > CORNERING_AY_MPS2)
    cornering &= np.nan_to_num(speed) >= CORNERING_SPEED_MPS
    seconds = float(cornering.sum() * dt)
    turning = float((mask & (np.abs(np.nan_to_num(ay)) > CORNERING_AY_MPS2)).sum() * dt)
    if seconds < MIN_CORNERING_S <= turning:
        # Turning at walking pace is kinematic (δ = L/R): the slip angles are too small against
        # the steering's resolution to show any stiffness.
        raise NoCornering(
            f"lateral: not identified: {turning:.0f} s of turning, {seconds:.1f} s of it above "
            f"{CORNERING_SPEED_MPS:g} m/s (kinematic turning shows no cornering stiffness)"
        )
    if seconds < MIN_CORNERING_S:
        raise NoCornering(
            f"lateral: no usable cornering: {seconds:.1f} s with |a_y| > "
            f"{CORNERING_AY_MPS2:g} m/s² above {CORNERING_SPEED_MPS:g} m/s "
            f"(need {MIN_CORNERING_S:g} s)"
        )

    def arr(x):
        return device_array(np.where(valid, x, 0.0) if x.dtype.kind == "f" else x)

    return CorneringObservations(
        speed=device_array(np.where(valid, speed, 10.0)),
        yaw_rate=arr(yaw_rate),
        yaw_acceleration=arr(yaw_acceleration),
        ay=arr(ay),
        steering=arr(steering),
        mask=device_array(mask),
        mask_kinematic=device_array(kinematic),
        longitudinal=device_array(longitudinal),
        ax=arr(ax),
        dt_s=float(dt),
        road_wheel=road_wheel,
        mass_kg=jnp.asarray(float(vehicle.mass_kg)),
        wheelbase_m=jnp.asarray(float(vehicle.wheelbase_m)),
        cog_to_front_axle_m=jnp.asarray(float(vehicle.cog_to_front_axle_m)),
        yaw_inertia_kgm2=jnp.asarray(float(vehicle.yaw_inertia_kgm2)),
        steering_ratio=jnp.asarray(float(vehicle.steering_ratio)),
        cornering_seconds=jnp.asarray(seconds),
    )
