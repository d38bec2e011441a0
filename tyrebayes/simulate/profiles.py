"""Speed, lateral-acceleration and road-grade profiles of a simulated drive (kinematics only).

A profile is what the driver and the road ask for: the planned speed V(t), the lateral
acceleration a_y(t) of corners and lane changes, and the road grade θ(t). Forces, slips and sensors
are added by :mod:`tyrebayes.simulate.drive`. ABS events are marked here with a planned
deceleration; the drive replaces it with the deceleration the tyres actually deliver and corrects
the following *recovery* segment so that the rest of the drive keeps its planned speeds.

Everything is NumPy and vectorised per segment (a one-hour drive has a few hundred segments), so a
one-hour 100 Hz profile takes a few tens of milliseconds.

Examples
--------
>>> import numpy as np
>>> p = make_profile(np.random.default_rng(0), duration_s=60.0, sample_rate_hz=100.0,
...                  mu_surface=1.0)
>>> p.speed_mps.shape
(6000,)
"""

from __future__ import annotations

import numpy as np

from ..physics.vehicle import GRAVITY_MPS2
from .noise_processes import ou_process as ou_process
from .noise_processes import smooth_noise as smooth_noise
from .profile_options import _L, _Y
from .profile_options import LAT_LABELS as LAT_LABELS
from .profile_options import LONG_LABELS as LONG_LABELS
from .profile_options import MIN_CURVE_RADIUS_M as MIN_CURVE_RADIUS_M
from .profile_options import AbsEvent as AbsEvent
from .profile_options import DriveProfile as DriveProfile
from .profile_options import ProfileOptions as ProfileOptions


def _smooth_change(v0: float, v1: float, a_peak: float, dt: float) -> np.ndarray:
    """Speeds of a jerk-limited change v0 → v1: a(t) = a_peak sin²(π t/T), T = 2|Δv|/a_peak."""
    dv = v1 - v0
    duration = max(2.0 * abs(dv) / a_peak, 2 * dt)
    m = max(int(round(duration / dt)), 2)
    s = (np.arange(1, m + 1)) / m
    # ∫ sin² = (s − sin(2πs)/(2π)) / 1 over the normalised time s ∈ [0, 1].
    return v0 + dv * (s - np.sin(2 * np.pi * s) / (2 * np.pi))


class _Planner:
    """Appends speed segments; the state is the current speed and the samples so far."""

    def __init__(self, rng: np.random.Generator, dt: float, n: int, opts: ProfileOptions, a_max):
        self.rng, self.dt, self.n, self.opts, self.a_max = rng, dt, n, opts, a_max
        self.speed: list[np.ndarray] = []
        self.label: list[np.ndarray] = []
        self.count = 0
        self.v = opts.initial_speed_kmh / 3.6

    def add(self, speeds: np.ndarray, label: str) -> int:
        start = self.count
        self.speed.append(np.asarray(speeds, dtype=float))
        self.label.append(np.full(len(speeds), _L[label], dtype=np.int8))
        self.count += len(speeds)
        if len(speeds):
            self.v = float(speeds[-1])
        return start

    def change_to(self, v1: float, a_peak: float, label: str | None = None) -> int:
        lab = label or ("accelerate" if v1 > self.v else "decelerate")
        return self.add(_smooth_change(self.v, v1, a_peak, self.dt), lab)

    def cruise(self, duration_s: float) -> None:
        m = max(int(duration_s / self.dt), 1)
        # Wander accelerations (sd ≈ sd_v / 4 s) shrink with the grip on low-friction roads.
        sd = self.opts.speed_wander_mps * min(1.0, self.a_max / 1.5)
        wander = smooth_noise(self.rng, m, self.dt, 4.0, sd)
        # Taper the wander to zero at both ends so speed and acceleration stay continuous.
        taper = np.minimum(1.0, np.minimum(np.arange(m), np.arange(m)[::-1]) * self.dt / 3.0)
        taper = np.sin(0.5 * np.pi * taper) ** 2
        v = np.maximum(self.v + wander * taper, 0.5)
        self.add(v, "cruise")


def surface_speed_limit_kmh(mu_surface: float) -> float:
    """Highest cruise speed a driver chooses on a surface: 50 + 80 μ km/h within [60, 130].

    Ice (μ 0.15) gives ~62 km/h, snow (0.45) ~86, wet (0.8) ~114, dry (1.0) 130.
    """
    return float(np.clip(50.0 + 80.0 * mu_surface, 60.0, 130.0))


def _pick_speed(
    rng: np.random.Generator, opts: ProfileOptions, v_now: float, cap_kmh: float
) -> float:
    speeds = np.minimum(np.asarray(opts.cruise_speeds_kmh), cap_kmh) / 3.6
    w = np.asarray(opts.cruise_weights, dtype=float)
    # Avoid picking the speed the car already drives at.
    w = np.where(np.abs(speeds - v_now) < 1.0, 0.0, w)
    w = w if w.sum() > 0 else np.ones_like(w)
    return float(rng.choice(speeds, p=w / w.sum()))


def _event_times(
    rng: np.random.Generator, rate_per_hour: float, duration_s: float, exact: int = -1
) -> np.ndarray:
    """Event times: exactly ``exact`` spread evenly with jitter, or a Poisson process."""
    if exact >= 0:
        if exact == 0:
            return np.zeros(0)
        slots = (np.arange(exact) + 0.25 + 0.5 * rng.random(exact)) / exact
        return np.sort(slots * duration_s)
    k = rng.poisson(rate_per_hour * duration_s / 3600.0)
    return np.sort(rng.random(k) * duration_s)


def _longitudinal(
    rng: np.random.Generator,
    duration_s: float,
    dt: float,
    opts: ProfileOptions,
    a_max: float,
    brake_max: float,
    abs_decel: float,
    cap_kmh: float,
) -> tuple[np.ndarray, np.ndarray, list[AbsEvent]]:
    n = int(round(duration_s / dt))
    plan = _Planner(rng, dt, n, opts, a_max)
    plan.v = min(plan.v, cap_kmh / 3.6)
    # ABS events need room: at least their duration plus a recovery; keep them off the last 20 s.
    abs_times = list(
        _event_times(rng, opts.abs_events_per_hour, max(duration_s - 20.0, 1.0), opts.n_abs_events)
    )
    hard_times = list(_event_times(rng, opts.hard_brakes_per_hour, duration_s))
    events: list[AbsEvent] = []
    a_lo, a_hi = opts.accel_range_mps2
    a_hi_eff = max(min(a_hi, a_max), 0.05)
    a_lo_eff = min(a_lo, a_hi_eff)
    while plan.count < n:
        t_now = plan.count * dt
        if abs_times and t_now >= abs_times[0]:
            abs_times.pop(0)
            # Full braking needs speed: get up to at least 60 km/h first.
            if plan.v < 60 / 3.6:
                plan.change_to(
                    min(float(rng.uniform(70, 100)), cap_kmh) / 3.6, rng.uniform(a_lo_eff, a_hi_eff)
                )
            d_abs = rng.uniform(*opts.abs_duration_s)
            m = max(int(d_abs / dt), 2)
            v_end = max(plan.v - abs_decel * m * dt, 3.0)
            m = max(int((plan.v - v_end) / abs_decel / dt), 2)
            start = plan.add(plan.v - abs_decel * dt * np.arange(1, m + 1), "abs")
            target = _pick_speed(rng, opts, plan.v, cap_kmh)
            plan.change_to(max(target, plan.v + 3.0), rng.uniform(a_lo_eff, a_hi_eff), "recovery")
            events.append(AbsEvent(start, start + m, plan.count))
            continue
        if hard_times and t_now >= hard_times[0]:
            hard_times.pop(0)
            if plan.v > 8.0:
                v1 = plan.v * rng.uniform(0.3, 0.7)
                plan.change_to(v1, rng.uniform(0.6, 0.95) * brake_max, "hard_brake")
                continue
        target = _pick_speed(rng, opts, plan.v, cap_kmh)
        if rng.random() < opts.stop_probability:
            plan.change_to(0.0, rng.uniform(a_lo_eff, a_hi_eff))
            plan.add(np.zeros(int(rng.uniform(*opts.stop_duration_s) / dt)), "stop")
        plan.change_to(target, rng.uniform(a_lo_eff, a_hi_eff))
        plan.cruise(float(np.clip(rng.exponential(opts.mean_cruise_s), 5.0, 180.0)))
    speed = np.concatenate(plan.speed)[:n]
    label = np.concatenate(plan.label)[:n]
    events = [
        AbsEvent(e.start, min(e.stop, n), min(e.recovery_stop, n)) for e in events if e.start < n
    ]
    return np.maximum(speed, 0.0), label, events


def _lateral(
    rng: np.random.Generator,
    speed: np.ndarray,
    long_label: np.ndarray,
    dt: float,
    opts: ProfileOptions,
    ay_max: float,
) -> tuple[np.ndarray, np.ndarray]:
    n = len(speed)
    duration = n * dt
    ay = np.zeros(n)
    label = np.zeros(n, dtype=np.int8)
    for event, rate in (
        ("corner", opts.corners_per_hour),
        ("lane_change", opts.lane_changes_per_hour),
    ):
        for t0 in _event_times(rng, rate, duration):
            i0 = int(t0 / dt)
            if event == "corner":
                ramp, hold = rng.uniform(1.5, 3.0), rng.uniform(2.0, 10.0)
                total = 2 * ramp + hold
                s = np.arange(int(total / dt)) * dt
                shape = np.clip(np.minimum(s / ramp, (total - s) / ramp), 0.0, 1.0)
                shape = np.sin(0.5 * np.pi * shape) ** 2
                amp = rng.uniform(*opts.corner_ay_mps2)
            else:
                period = rng.uniform(3.0, 6.0)
                s = np.arange(int(period / dt)) * dt
                shape = np.sin(2 * np.pi * s / period)
                amp = rng.uniform(*opts.lane_change_ay_mps2)
            i1 = min(i0 + len(shape), n)
            # No overlap with another lateral event, and never during ABS (straight-line braking).
            if i1 <= i0 or np.any(label[i0:i1]) or np.any(long_label[i0:i1] == _L["abs"]):
                continue
            sign = rng.choice([-1.0, 1.0])
            ay[i0:i1] = sign * min(amp, ay_max) * shape[: i1 - i0]
            label[i0:i1] = _Y[event]
    # Gentle road curvature everywhere (motorway bends), a_y sd 0.1 m/s².
    ay += smooth_noise(rng, n, dt, 3.0, 0.1)
    # Lateral acceleration needs speed; fade it out below 5 m/s (parking speeds, stops), and keep
    # curve radii above MIN_CURVE_RADIUS_M (a_y ≤ V²/R_min).
    fade = np.clip((speed - 2.0) / 3.0, 0.0, 1.0)
    cap = speed**2 / MIN_CURVE_RADIUS_M
    # ABS braking happens on a straight road: no lateral acceleration within 1 s of an ABS event.
    abs_near = np.convolve(
        (long_label == _L["abs"]).astype(float), np.ones(2 * int(1.0 / dt) + 1), mode="same"
    )
    fade = np.where(abs_near > 0, 0.0, fade)
    ay = np.clip(ay * fade, -cap, cap)
    return ay, np.where(fade > 0, label, 0).astype(np.int8)


def make_profile(
    rng: np.random.Generator,
    *,
    duration_s: float,
    sample_rate_hz: float,
    mu_surface: float,
    options: ProfileOptions | None = None,
    traction_limit_mps2: float | None = None,
) -> DriveProfile:
    """Plan a drive: speeds, lateral accelerations, grade and segment labels.

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source (the drive's seed).
    duration_s : float
        Duration [s].
    sample_rate_hz : float
        Rate of the uniform grid [Hz].
    mu_surface : float
        Friction potential of the surface for this tyre [-]; limits ordinary accelerations to 30 %,
        hard braking to 75 % and lateral accelerations to 50 % of μ g, the grade to 0.2 μ and
        cruise speeds to :func:`surface_speed_limit_kmh`, and sets the planned ABS deceleration
        0.95 μ g (replaced by the drive with what the tyres deliver).
    options : ProfileOptions, optional
        The driver (defaults: mixed urban/rural/motorway driving, no ABS events).
    traction_limit_mps2 : float, optional
        Largest planned acceleration [m/s²] (default 0.3 μ g; the drive passes 0.3 μ g times the
        driven axle's static load share).

    Returns
    -------
    DriveProfile
    """
    opts = options or ProfileOptions()
    if not duration_s > 0 or not sample_rate_hz > 0:
        raise ValueError(
            f"profile: expected duration_s > 0 and sample_rate_hz > 0, got {duration_s}, "
            f"{sample_rate_hz}"
        )
    if not mu_surface > 0:
        raise ValueError(f"profile: expected mu_surface > 0, got {mu_surface}")
    dt = 1.0 / sample_rate_hz
    mu_g = mu_surface * GRAVITY_MPS2
    a_max = 0.3 * mu_g if traction_limit_mps2 is None else traction_limit_mps2
    speed, long_label, events = _longitudinal(
        rng,
        duration_s,
        dt,
        opts,
        a_max,
        min(0.75 * mu_g, 9.0),
        0.95 * mu_g,
        surface_speed_limit_kmh(mu_surface),
    )
    n = len(speed)
    accel = np.gradient(speed, dt)
    ay, lat_label = _lateral(rng, speed, long_label, dt, opts, 0.5 * mu_g)
    # Roads steeper than the tyres can manage are not driven: soft cap at 0.2 μ (≤ 0.1 rad).
    grade_cap = min(0.1, 0.2 * mu_surface)
    grade = grade_cap * np.tanh(smooth_noise(rng, n, dt, 30.0, opts.grade_sd_rad) / grade_cap)
    return DriveProfile(
        time_s=np.arange(n) * dt,
        speed_mps=speed,
        accel_mps2=accel,
        ay_mps2=ay,
        grade_rad=grade,
        long_label=long_label,
        lat_label=lat_label,
        abs_events=tuple(events),
    )


def profile_from_trace(
    time_s: np.ndarray,
    speed_mps: np.ndarray,
    *,
    sample_rate_hz: float,
    ay_mps2: np.ndarray | None = None,
    grade_rad: np.ndarray | None = None,
    smoothing_s: float = 0.5,
) -> DriveProfile:
    """A profile that replays a recorded speed trace (e.g. a real log's GNSS speed).

    The trace (and ``ay_mps2``) is interpolated onto a uniform grid and smoothed with a centred
    moving average of ``smoothing_s`` (GNSS speed is noisy and held); labels follow the
    acceleration (|a| < 0.3 m/s² cruise, above accelerate, below decelerate, V < 0.5 m/s stop).
    No ABS events.

    Examples
    --------
    >>> t = np.linspace(0.0, 10.0, 101)
    >>> p = profile_from_trace(t, 10.0 + 0.5 * t, sample_rate_hz=50.0)
    >>> p.speed_mps.shape, round(float(p.accel_mps2[250]), 3)
    ((500,), 0.5)
    """
    time_s = np.asarray(time_s, dtype=float)
    speed_mps = np.asarray(speed_mps, dtype=float)
    if time_s.ndim != 1 or time_s.shape != speed_mps.shape or time_s.size < 2:
        raise ValueError(
            f"profile_from_trace: expected equal 1-D time and speed arrays of >= 2 samples, got "
            f"{time_s.shape} and {speed_mps.shape}"
        )
    if not np.all(np.diff(time_s) > 0):
        raise ValueError("profile_from_trace: expected strictly increasing time, got otherwise")
    dt = 1.0 / sample_rate_hz
    n = int((time_s[-1] - time_s[0]) / dt)
    t = np.arange(n) * dt
    v = np.interp(t + time_s[0], time_s, speed_mps)
    k = max(int(round(smoothing_s / dt)) | 1, 1)

    def smooth(x):
        if k == 1:
            return x
        return np.convolve(np.pad(x, k // 2, mode="edge"), np.ones(k) / k, mode="valid")

    v = np.maximum(smooth(v), 0.0)
    a = np.gradient(v, dt)
    label = np.where(a > 0.3, _L["accelerate"], np.where(a < -0.3, _L["decelerate"], _L["cruise"]))
    label = np.where(v < 0.5, _L["stop"], label).astype(np.int8)

    def on_grid(x):
        return np.zeros(n) if x is None else np.interp(t + time_s[0], time_s, np.asarray(x, float))

    # Smoothed like the speed: a recorded a_y (e.g. yaw rate × speed) carries sensor noise whose
    # derivative would otherwise become yaw accelerations and front lateral forces.
    ay = smooth(on_grid(ay_mps2))
    lat = np.where(np.abs(ay) > 1.0, _Y["corner"], _Y["straight"]).astype(np.int8)
    return DriveProfile(
        time_s=t,
        speed_mps=v,
        accel_mps2=a,
        ay_mps2=ay,
        grade_rad=on_grid(grade_rad),
        long_label=label,
        lat_label=lat,
        abs_events=(),
    )
