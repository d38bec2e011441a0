"""The signal pipeline: a validated stream to per-sample tyre features with noise levels.

Steps (thesis chapter 4.3):

1. Smooth the channels with a short NaN-aware moving average (``smoothing_s``).
2. Translate each wheel's speed R·Ω to the vehicle's longitudinal speed (curve compensation with
   yaw rate and road-wheel angle). Eq. 4.23 takes the body's sideslip β = 0; the steered
   wheels' speeds are read here with the single-track model's steady-state V_y instead
   (:func:`_front_terms`), which in a tight low-speed turn is worth 1-2 % of slip.
3. V_x from the non-driven wheels, with the spin check of chapter 4.3.2 (driven vs non-driven
   wheel on the same side) and a lock check between the two non-driven wheels.
4. Slip σ_x = (R·Ω − V)/V per wheel and per axle (eq. 2.1), with nominal radii: per-wheel radius
   offsets are estimated separately (:class:`StreamNuisances`), never silently applied. Wheel
   speeds only show slip *relative to the wheels that give V_x*: under braking the non-driven
   wheels brake and slip too, so the driven axle's measured slip is about σ_driven − σ_free
   (for AWD, relative to the median wheel, biased towards zero). Traction samples are clean.
5. IMU offset from ax − dV_x/dt; the offset-corrected ax keeps the road grade, which is exactly
   what the force balance needs. The body's squat and dive (the vehicle's pitch gradient k) make
   the IMU over-read a_x by 1 + g·k; that gain is removed, before the offset estimate too. The
   IMU's own scale factor is estimated against dV_x/dt and divided out as far as the evidence
   says the IMU is not calibrated (a dashcam's;
   :func:`~tyrebayes.streams.nuisances.imu_gain_correction`).
6. Axle forces from :func:`tyrebayes.physics.vehicle.single_track_inverse` (eq. 4.23) with drag
   and rolling resistance; axle loads with longitudinal load transfer; ρ_x = F_x / F_z.
7. Friction power w_x = |F_x V_x σ_x| (eq. 4.19a) and regime labels.

Examples
--------
>>> from tyrebayes._resources import data_dir
>>> from tyrebayes._domain import load_vehicle
>>> from tyrebayes.streams import read_stream, validate_stream
>>> vehicle = load_vehicle("suv_rav4")
>>> stream = validate_stream(read_stream(data_dir() / "comma2k19_rav4_segment.csv"), vehicle)
>>> feats = compute_features(stream, vehicle)
>>> 15 < float(feats.vx_mps[feats.valid].mean()) < 20
True
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ..physics.vehicle import (
    GRAVITY_MPS2,
    Vehicle,
    aero_drag,
    axle_loads,
    body_pitch_gain,
    rolling_resistance_force,
    single_track_inverse,
)
from .filters import PrefixSums, nan_moving_average, smoothed_derivative, window_samples
from .noise import local_noise_sd
from .nuisances import (
    ImuGainCorrection,
    StreamNuisances,
    estimate_ax_gain,
    estimate_ax_offset,
    estimate_radius_ratios,
    estimate_speed_scale,
    imu_gain_correction,
    mean_grade_sd,
)
from .order_stats import median, nanmedian_columns
from .schema import WHEEL_COLUMNS
from .segments import (
    DEFAULT_THRESHOLDS,
    FREE_ROLLING,
    SEGMENT_KINDS,
    SegmentThresholds,
    label_samples,
    summarize_segments,
)
from .validate import ValidatedStream, median_of_four

_NON_DRIVEN = {"fwd": (2, 3), "rwd": (0, 1), "awd": (0, 1, 2, 3)}


def _columns(*columns: np.ndarray) -> np.ndarray:
    """Columns side by side as an (n, k) array whose columns are contiguous (Fortran order).

    The pipeline works on whole columns (one wheel, one axle); in NumPy a reduction across a
    C-ordered row of four costs about ten column operations, and a moving average down a
    column of a C-ordered table a quarter more than down a contiguous one.
    """
    out = np.empty((len(columns), columns[0].shape[0]))
    for row, column in zip(out, columns, strict=True):
        row[:] = column
    return out.T


def _table(n: int, k: int) -> np.ndarray:
    """An empty (n, k) array with contiguous columns, for results written column by column."""
    return np.empty((k, n)).T


def _row_mean(x: np.ndarray, columns: tuple[int, ...], out: np.ndarray | None = None) -> np.ndarray:
    """``x[:, columns].mean(axis=1)`` column by column, summed in NumPy's order."""
    total = np.empty(x.shape[0]) if out is None else out
    np.copyto(total, x[:, columns[0]])
    for i in columns[1:]:
        total += x[:, i]
    total /= len(columns)
    return total


class StreamFeatures(eqx.Module):
    """Per-sample features of one stream (NumPy arrays on a uniform time base) and metadata.

    Wheel order is (fl, fr, rl, rr); axle order (front, rear). Slip and force are NaN where
    ``valid`` is False. The ``*_sd`` arrays are 1-sigma measurement noise of the smoothed features;
    neighbouring samples are correlated over ``smoothing_s``.

    Attributes
    ----------
    time_s : time base [s]
    vx_mps, vx_sd_mps : vehicle longitudinal speed V_x and its noise [m/s]
    wheel_vx_mps : (n, 4) each wheel's R·Ω translated to V_x (nominal radius) [m/s]
    slip, slip_sd : (n, 4) per-wheel σ_x and its noise [-]
    slip_axle : (n, 2) per-axle mean σ_x [-]
    slip_driven, slip_driven_sd : σ_x of the driven axle (all four wheels for AWD) [-]
    fx_axle_n, fz_axle_n : (n, 2) longitudinal force and load per axle [N]
    rho_axle : (n, 2) ρ_x = F_x / F_z per axle [-]
    rho_driven, rho_driven_sd : ρ_x of the driven axle (total for AWD) and its noise [-]
    rho_driven_traction : ρ_x of the driven axle with the traction split at every sample, braking
        included [-]: continuous through zero force, where ``rho_driven`` switches to the brake
        balance sample by sample (see :func:`tyrebayes.inference.observations_from_features`).
        Its a_x is the wheel speeds' dV_x/dt plus the low-passed IMU − dV_x/dt (the road grade),
        where V_x comes from free-rolling wheels (:func:`_traction_acceleration`)
    rho_driven_traction_sd : noise of ``rho_driven_traction`` at the smoothing scale [-]
    rho_total_traction : ΣF_x/ΣF_z with the same a_x as ``rho_driven_traction`` [-]: whether the
        tyres push or brake
    load_change_driven : ΔF_z/F_z,static of the driven axle with the same a_x [-]: the
        longitudinal load transfer m a_x h / L over the axle's static load (0 for AWD, whose
        two axles' transfers cancel), which the tyre model's load sensitivity reads
    friction_power_w : |F_x V_x σ_x| of the driven axle, eq. 4.19a [W]
    ax_mps2 : IMU ax minus the estimated offset (includes road grade) [m/s²]
    ay_mps2 : IMU ay minus its offset [m/s²]
    dvx_dt_mps2 : dV_x/dt from the wheels [m/s²]
    grade_rad : road grade estimate asin((ax − dV_x/dt)/g), uphill positive [rad]
    yaw_rate_radps, yaw_acc_radps2 : yaw rate and its derivative
    steer_rad : front road-wheel angle δ [rad]
    resistance_n : drag + rolling resistance [N]
    label : index into :data:`SEGMENT_KINDS`
    valid : V_x usable (moving, no gap)
    spin : spin/lock check fired (chapter 4.3.2)
    filled : sample bridged over a dropped sample
    nuisances : :class:`StreamNuisances`
    noise : per raw channel, white-noise sd [channel unit]
    sample_rate_hz, smoothing_s, driven_axle, vx_source, brake_front_share : metadata
    """

    time_s: Float[np.ndarray, "n"]
    vx_mps: Float[np.ndarray, "n"]
    vx_sd_mps: Float[np.ndarray, "n"]
    wheel_vx_mps: Float[np.ndarray, "n 4"]
    slip: Float[np.ndarray, "n 4"]
    slip_sd: Float[np.ndarray, "n 4"]
    slip_axle: Float[np.ndarray, "n 2"]
    slip_driven: Float[np.ndarray, "n"]
    slip_driven_sd: Float[np.ndarray, "n"]
    fx_axle_n: Float[np.ndarray, "n 2"]
    fz_axle_n: Float[np.ndarray, "n 2"]
    rho_axle: Float[np.ndarray, "n 2"]
    rho_driven: Float[np.ndarray, "n"]
    rho_driven_sd: Float[np.ndarray, "n"]
    rho_driven_traction: Float[np.ndarray, "n"]
    rho_driven_traction_sd: Float[np.ndarray, "n"]
    rho_total_traction: Float[np.ndarray, "n"]
    load_change_driven: Float[np.ndarray, "n"]
    friction_power_w: Float[np.ndarray, "n"]
    ax_mps2: Float[np.ndarray, "n"]
    ay_mps2: Float[np.ndarray, "n"]
    dvx_dt_mps2: Float[np.ndarray, "n"]
    grade_rad: Float[np.ndarray, "n"]
    yaw_rate_radps: Float[np.ndarray, "n"]
    yaw_acc_radps2: Float[np.ndarray, "n"]
    steer_rad: Float[np.ndarray, "n"]
    resistance_n: Float[np.ndarray, "n"]
    label: Int[np.ndarray, "n"]
    valid: Bool[np.ndarray, "n"]
    spin: Bool[np.ndarray, "n"]
    filled: Bool[np.ndarray, "n"]
    nuisances: StreamNuisances
    noise: dict[str, float] = eqx.field(static=True)
    sample_rate_hz: float = eqx.field(static=True)
    smoothing_s: float = eqx.field(static=True)
    driven_axle: str = eqx.field(static=True)
    vx_source: str = eqx.field(static=True)
    brake_front_share: float = eqx.field(static=True)

    def segments(self, min_segment_s: float = 0.5) -> dict[str, dict[str, float | int]]:
        """Count and seconds per regime (see :func:`summarize_segments`)."""
        return summarize_segments(self.time_s, self.label, min_segment_s)

    def mask(self, kind: str) -> Bool[np.ndarray, "n"]:
        """Samples labelled ``kind`` (one of :data:`SEGMENT_KINDS`)."""
        if kind not in SEGMENT_KINDS:
            raise ValueError(f"mask: expected one of {SEGMENT_KINDS}, got {kind!r}")
        return self.label == SEGMENT_KINDS.index(kind)


def _wheel_to_vx(
    wheel_radps: np.ndarray,
    yaw: np.ndarray,
    vehicle: Vehicle,
    trig: tuple[np.ndarray, np.ndarray],
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Each wheel's longitudinal speed translated to the CoG V_x.

    A wheel at (x_i, y_i) moves with (V_x − ψ̇ y_i, V_y + ψ̇ x_i); the front wheels point along δ,
    so the front wheels' speed u_i = R Ω_i = V_x cos δ + (V_y + ψ̇ l_f) sin δ, with the front
    axle's lateral speed V_y + ψ̇ l_f = ψ̇ L − α_r V_x of :func:`_front_terms`. Solved for V_x:
    V_x = (u_i − ψ̇ L sin δ)/(cos δ − α_r sin δ) + ψ̇ y_i; the rear wheels need only the ψ̇ y_i
    term. ``trig`` is (1/(cos δ − α_r sin δ), ψ̇ L sin δ), computed once for several calls; the
    output is written in place, column by column (no temporaries of shape (n, 4)).
    """
    inv_cos, yaw_l_sin = trig
    yaw_half = yaw * (0.5 * vehicle.track_width_m)
    if out is None:
        out = np.empty(wheel_radps.shape[::-1]).T  # columns contiguous
    radius = vehicle.wheel_radius_m
    for i, sign in enumerate((1.0, -1.0, 1.0, -1.0)):
        col = out[:, i]
        np.multiply(wheel_radps[:, i], radius, out=col)
        if i < 2:
            col -= yaw_l_sin
            col *= inv_cos
        if sign > 0:
            col += yaw_half
        else:
            col -= yaw_half
    return out


# Cornering stiffness of the rear axle per unit of its load [1/rad]: radial passenger tyres have
# a cornering coefficient of about 0.2 per degree (Gillespie 1992, Fundamentals of Vehicle
# Dynamics, ch. 6), 11.5 per radian. It sets only the rear slip angle's share of the front
# axle's lateral speed, α_r sin δ, a few 1e-4 of slip where δ is large; an error of half of it
# moves a window's slip by less than its noise.
REAR_CORNERING_PER_RAD = 11.5


def _front_terms(
    yaw: np.ndarray, steer: np.ndarray, ay: np.ndarray, vehicle: Vehicle
) -> tuple[np.ndarray, np.ndarray]:
    """(1/(cos δ − α_r sin δ), ψ̇ L sin δ) of :func:`_wheel_to_vx`.

    The front axle's lateral speed from the single-track model in a steady turn: the rear axle
    moves sideways at −α_r V_x, with α_r = F_yr/C_r = a_y/(g c_r) (the rear axle carries
    m a_y l_f/L, its static load times a_y/g; c_r = :data:`REAR_CORNERING_PER_RAD`), so
    V_y + ψ̇ l_f = ψ̇ L − α_r V_x. With β = 0 (thesis eq. 4.23) the term ψ̇ l_r sin δ/V_x is
    left out: in a turn of radius R at walking pace it is l_r L/R², 1.9 % of slip at R = 15 m
    (l_r 1.64 m, L 2.65 m), where the slip a wheel transmits is a few per mille.
    """
    sin, cos = np.sin(steer), np.cos(steer)
    rear_slip_angle = ay / (GRAVITY_MPS2 * REAR_CORNERING_PER_RAD)
    # In place: 1/(cos − α_r sin) in the cosine's array, ψ̇ L sin in the sine's.
    rear_slip_angle *= sin
    cos -= rear_slip_angle
    np.divide(1.0, cos, out=cos)
    sin *= yaw * vehicle.wheelbase_m
    return cos, sin


def _vehicle_speed(
    wheel_vx: np.ndarray, drive: str, spin_threshold: float
) -> tuple[np.ndarray, np.ndarray]:
    """V_x from the non-driven wheels and the spin/lock flag (thesis 4.3.2)."""
    if drive == "awd":
        # No free wheel: the median of four is robust to one spinning or locking wheel; slip is
        # then measured relative to the other driven wheels (biased towards zero).
        median = median_of_four(wheel_vx)
        return median, np.zeros(wheel_vx.shape[0], dtype=bool)
    a, b = _NON_DRIVEN[drive]
    va, vb = wheel_vx[:, a], wheel_vx[:, b]
    mean = np.add(va, vb)
    mean *= 0.5
    difference = np.subtract(va, vb)
    np.abs(difference, out=difference)
    limit = np.abs(mean)
    limit *= spin_threshold
    with np.errstate(invalid="ignore", divide="ignore"):
        disagree = difference > limit
    # A non-driven wheel cannot spin up, only lock under braking: the faster one is closer to V.
    np.maximum(va, vb, out=limit)
    np.copyto(mean, limit, where=disagree)
    return mean, disagree


def _slip_noise_probe(
    slip_velocity: np.ndarray,
    slip_velocity_sums: PrefixSums,
    force_velocity: np.ndarray,
    pushing: np.ndarray,
    window: int,
) -> np.ndarray:
    """The driven axle's slip velocity R·Ω − V_x less the part that follows the force.

    The slip velocity σV_x moves with the force over 0.2-1 s, the scale at which its noise is
    measured, so taken as it is its real changes count as noise (several times the noise on
    drives with brisk acceleration changes: a test with a noise-free 0.7 Hz ripple). Here the
    part of it that the force explains linearly, b·ρV_x, is taken off first, with b (≈ 1/C_x)
    from a least-squares fit over the drive of the two signals high-passed like
    :func:`~tyrebayes.streams.noise.local_noise_sd` does; what is left is sensor noise and what
    the linear fit misses. Only where the tyres push: under braking the reference wheels brake
    too and the relation is another (NaN there; the caller takes the plain slip velocity's
    noise where no pushing sample is near). ``slip_velocity_sums`` are the slip velocity's
    :class:`~tyrebayes.streams.filters.PrefixSums`, which the caller's noise estimate of the
    same signal reads too.
    """
    half = (5 * window) // 2  # nan_moving_average's half-window for 5 * window samples
    s = slip_velocity - slip_velocity_sums.window_mean(half)
    r = force_velocity - nan_moving_average(force_velocity, 5 * window)
    ok = np.isfinite(s) & np.isfinite(r) & pushing
    r_ok = r[ok]
    denominator = float(np.sum(r_ok**2))
    slope = float(np.sum(s[ok] * r_ok)) / denominator if denominator > 0 else 0.0
    return np.where(pushing, slip_velocity - slope * force_velocity, np.nan)


def _vx_noise_probe(wheel_vx: np.ndarray, drive: str) -> np.ndarray:
    """A zero-mean combination of the V_x wheels with the noise of their mean (motion cancels)."""
    if drive == "awd":
        return 0.25 * (wheel_vx[:, 0] - wheel_vx[:, 1] + wheel_vx[:, 2] - wheel_vx[:, 3])
    a, b = _NON_DRIVEN[drive]
    return 0.5 * (wheel_vx[:, a] - wheel_vx[:, b])


# Low-pass of IMU a_x − dV_x/dt that carries the road grade into the traction force [s]: hills
# change over hundreds of metres (tens of seconds), the IMU's coloured noise over seconds.
GRADE_LOWPASS_S = 10.0


def _traction_acceleration(
    vx: PrefixSums,
    ax_imu: np.ndarray,
    vx_probe: PrefixSums,
    drive: str,
    dt: float,
    window: int,
    rate: float,
    span: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Longitudinal specific force for the traction force, and its noise sd [m/s²].

    The IMU's a_x carries coloured noise and vibration over 0.2-1 s, the scale of real changes of
    acceleration, so that neither a high-pass nor the smoothing tells them apart; on drives from
    an independent generator its window error was 0.011-0.047 of ρ_x, as large as
    the window's stated noise and, in the slip-on-force regression, an attenuation of the slope.
    Where V_x comes from free-rolling wheels (FWD, RWD) their dV_x/dt measures the same
    acceleration with the wheel speeds' far smaller noise, and only
    what it lacks, g·sin(grade) (with the IMU offset left after correction), comes from the IMU,
    low-passed over :data:`GRADE_LOWPASS_S`: a complementary filter. For AWD cars no wheel rolls
    freely and the IMU is used as it is.

    The noise is the local RMS of the same derivative of the V_x wheels' difference (the motion
    cancels, their noise does not), with the IMU's share through the low-pass added.
    """
    if drive == "awd":
        return ax_imu, np.full_like(ax_imu, np.nan)
    dvx_dt = vx.smoothed_derivative(window // 2, dt)
    lowpass = window_samples(GRADE_LOWPASS_S, rate)
    # The IMU's error with the motion removed (a_x − dV_x/dt): its low-pass is the grade term,
    # its noise through the low-pass the IMU's share of the error (one set of prefix sums).
    imu_error = ax_imu - dvx_dt
    imu_error_sums = PrefixSums.of(imu_error)
    grade_accel = imu_error_sums.window_mean(lowpass // 2)
    probe = vx_probe.smoothed_derivative(window // 2, dt)
    probe_sums = PrefixSums.of(probe)
    probe -= probe_sums.window_mean(span // 2)
    # probe² has probe's NaN: the same counts.
    derivative_sd = np.sqrt(PrefixSums.of(probe**2, like=probe_sums).window_mean(span // 2))
    imu_sd = local_noise_sd(imu_error, window, span, prefix=imu_error_sums)
    imu_sd *= np.sqrt(window / lowpass)
    return dvx_dt + grade_accel, np.hypot(derivative_sd, imu_sd)


def _spin_check(wheel_vx: np.ndarray, vx: np.ndarray, drive: str, threshold: float) -> np.ndarray:
    """Driven vs non-driven wheel on the same side differing by more than ``threshold``."""
    if drive == "awd":
        pairs = ((0, 2), (1, 3))
    else:
        d = (0, 1) if drive == "fwd" else (2, 3)
        nd = _NON_DRIVEN[drive]
        pairs = ((d[0], nd[0]), (d[1], nd[1]))
    left, right = (np.subtract(wheel_vx[:, i], wheel_vx[:, j]) for i, j in pairs)
    np.abs(left, out=left)
    np.abs(right, out=right)
    np.maximum(left, right, out=left)
    limit = np.abs(vx)
    limit *= threshold
    with np.errstate(invalid="ignore"):
        return (left > limit) & np.isfinite(vx)


# Fixed chunk length for the JAX force balance: one compilation per process serves logs of any
# length (a new shape would recompile), and the cost stays linear in duration.
_CHUNK = 65536


class _AxleForces(eqx.Module):
    """The force balance of every sample, for the IMU's a_x and for the traction a_x [N].

    Per-axle pairs (front, rear) are (n, 2) views of one block, columns contiguous.
    """

    resistance: Float[np.ndarray, "n"]  # drag + rolling resistance
    fx_axle: Float[np.ndarray, "n 2"]  # traction split, or the brake balance under braking
    fz_axle: Float[np.ndarray, "n 2"]
    fx_traction: Float[np.ndarray, "n 2"]  # traction a_x, traction split at every sample
    fz_traction: Float[np.ndarray, "n 2"]


@eqx.filter_jit
def _force_balance_chunk(
    vehicle: Vehicle,
    braking_vehicle: Vehicle,
    ax: Float[Array, " c"],
    ax_traction: Float[Array, " c"],
    ay: Float[Array, " c"],
    yaw_acc: Float[Array, " c"],
    steer: Float[Array, " c"],
    speed: Float[Array, " c"],
) -> tuple[Float[Array, " c"], ...]:
    # Missing samples count as 0 (np.nan_to_num), a missing or negative speed as standstill
    # for the drag; done here, fused into the chunk's one pass, not as copies of whole logs.
    ax, ax_traction, ay, yaw_acc, steer = (
        jnp.nan_to_num(a) for a in (ax, ax_traction, ay, yaw_acc, steer)
    )
    speed = jnp.where(jnp.isfinite(speed), jnp.maximum(speed, 0.0), 0.0)
    resistance = aero_drag(vehicle, speed) + rolling_resistance_force(vehicle)
    fxf_t, _, fxr_t, _ = single_track_inverse(vehicle, ax, ay, yaw_acc, steer, resistance)
    fxf_b, _, fxr_b, _ = single_track_inverse(braking_vehicle, ax, ay, yaw_acc, steer, resistance)
    braking = vehicle.mass_kg * ax + resistance < 0.0
    fz_front, fz_rear = axle_loads(vehicle, ax)
    fxf_tt, _, fxr_tt, _ = single_track_inverse(
        vehicle, ax_traction, ay, yaw_acc, steer, resistance
    )
    fzf_tt, fzr_tt = axle_loads(vehicle, ax_traction)
    return (
        resistance,
        jnp.where(braking, fxf_b, fxf_t),
        jnp.where(braking, fxr_b, fxr_t),
        fz_front,
        fz_rear,
        fxf_tt,
        fxr_tt,
        fzf_tt,
        fzr_tt,
    )


def _force_balance(
    vehicle: Vehicle,
    ax: np.ndarray,
    ax_traction: np.ndarray,
    ay: np.ndarray,
    yaw_acc: np.ndarray,
    steer: np.ndarray,
    speed: np.ndarray,
    brake_front_share: float,
) -> _AxleForces:
    """Resistance, axle forces and loads for two a_x signals on the same motion [N].

    Eq. 4.23 inverted by :func:`single_track_inverse`: with ``ax``, traction follows the drive's
    split, braking the brake balance (front share), a property of the brake system, not of the
    drive; with ``ax_traction``, the traction split at every sample. One pass over the chunks
    serves both (the steering's sin/cos and the resistance are shared). NaN in the inputs
    counts as 0, and a missing or negative ``speed`` as standstill for the drag.
    """
    braking_vehicle = dataclasses.replace(
        vehicle, drive="awd", front_drive_fraction=float(brake_front_share)
    )
    n = ax.shape[0]
    inputs = (ax, ax_traction, ay, yaw_acc, steer, speed)
    # The chunk's outputs, a row each: the features keep the first block (resistance, axle
    # forces and loads), the traction block is an intermediate, freed after the forces step.
    kept, traction = np.empty((5, n)), np.empty((4, n))
    out = [*kept, *traction]
    for i in range(0, n, _CHUNK):
        size = min(_CHUNK, n - i)
        chunk = [a[i : i + size] for a in inputs]
        if size < _CHUNK:  # the last chunk, padded with zeros to the fixed length
            chunk = [np.pad(c, (0, _CHUNK - size)) for c in chunk]
        parts = _force_balance_chunk(vehicle, braking_vehicle, *(jnp.asarray(c) for c in chunk))
        for row, part in zip(out, parts, strict=True):
            row[i : i + size] = np.asarray(part)[:size]
    return _AxleForces(
        resistance=kept[0],
        fx_axle=kept[1:3].T,
        fz_axle=kept[3:5].T,
        fx_traction=traction[:2].T,
        fz_traction=traction[2:].T,
    )


def compute_features(
    stream: ValidatedStream,
    vehicle: Vehicle,
    *,
    smoothing_s: float = 0.2,
    spin_threshold: float = 0.1,
    brake_front_share: float = 0.7,
    ax_offset_mps2: float | None = None,
    ax_gain: float | None = None,
    thresholds: SegmentThresholds = DEFAULT_THRESHOLDS,
) -> StreamFeatures:
    """Per-sample features of a validated stream.

    Parameters
    ----------
    stream : ValidatedStream
        From :func:`tyrebayes.streams.validate_stream`.
    vehicle : Vehicle
        Vehicle parameters (nominal wheel radius, geometry, drive, drag, rolling resistance).
    smoothing_s : float
        Moving-average window applied to every channel [s]. 0.2 s removes most IMU vibration
        and wheel-speed quantisation while keeping the 1-2 Hz content of braking and traction.
    spin_threshold : float
        Relative speed difference that the spin check (chapter 4.3.2) calls spin or lock [-].
    brake_front_share : float
        Share of the braking force on the front axle (brake balance) [-]; about 0.7 for cars.
    ax_offset_mps2 : float, optional
        Known IMU longitudinal offset; by default estimated from ax − dV_x/dt.
    ax_gain : float, optional
        Known IMU longitudinal scale factor (ax reads this times the acceleration); by default
        estimated against the wheel speeds' dV_x/dt and divided out by its posterior mean under
        a calibrated-or-not mixture prior: next to nothing for an automotive IMU, about the
        estimate for a dashcam's (:func:`~tyrebayes.streams.nuisances.imu_gain_correction`).
    thresholds : SegmentThresholds
        Regime thresholds for the labels.

    Returns
    -------
    StreamFeatures

    Notes
    -----
    A chain of named steps, each returning a small Module: :func:`_motion` (smoothed channels,
    wheel speeds as V_x, vehicle speed, slips; thesis ch. 4.3), :func:`_wheel_noise` (noise at
    the smoothing scale), :func:`_imu_calibration` (IMU gain, offsets, grade), :func:`_forces`
    (force balance, eqs. 4.22/4.23, normalised forces and their noise) and :func:`_assemble`
    (regime labels, nuisances).
    """
    if not 0.0 <= brake_front_share <= 1.0:
        raise ValueError(f"brake_front_share: expected a value in [0, 1], got {brake_front_share}")
    if not spin_threshold > 0:
        raise ValueError(f"spin_threshold: expected a value > 0, got {spin_threshold}")
    if ax_gain is not None and not ax_gain > 0:
        raise ValueError(f"ax_gain: expected a value > 0, got {ax_gain}")
    scales = _Scales.of(stream.sample_rate_hz, smoothing_s)
    motion = _motion(stream, vehicle, scales, spin_threshold, thresholds)
    noise = _wheel_noise(motion, vehicle, scales, spin_threshold)
    imu = _imu_calibration(stream, vehicle, motion, scales, ax_offset_mps2, ax_gain)
    forces = _forces(stream, vehicle, motion, noise, imu, scales, brake_front_share)
    return _assemble(
        stream, vehicle, motion, noise, imu, forces, scales, thresholds, brake_front_share
    )


class _Scales(eqx.Module):
    """The pipeline's sample counts at the stream's rate: smoothing, derivative, noise span."""

    rate_hz: float
    dt_s: float
    window: int  # smoothing window [samples]
    deriv_window: int  # window of the speed and yaw-rate derivatives (≥ 0.5 s) [samples]
    span: int  # span of the local noise estimates (10 s) [samples]
    smoothing_s: float

    @classmethod
    def of(cls, rate_hz: float, smoothing_s: float) -> _Scales:
        return cls(
            rate_hz=float(rate_hz),
            dt_s=1.0 / rate_hz,
            window=window_samples(smoothing_s, rate_hz),
            deriv_window=window_samples(max(smoothing_s, 0.5), rate_hz),
            span=window_samples(10.0, rate_hz),
            smoothing_s=float(smoothing_s),
        )


class _Motion(eqx.Module):
    """Step 1: smoothed channels, each wheel's speed as V_x, the vehicle speed and slips."""

    omega_raw: Float[np.ndarray, "n 4"]  # unsmoothed wheel speeds [rad/s]
    gap: Bool[np.ndarray, "n"]  # a wheel speed missing
    yaw: Float[np.ndarray, "n"]  # smoothed yaw rate [rad/s]
    steer: Float[np.ndarray, "n"]  # front road-wheel angle [rad]
    ax_raw: Float[np.ndarray, "n"]  # smoothed IMU ax, uncorrected [m/s²]
    # Prefix sums of the raw IMU ax and of V_x: later steps smooth them over other windows.
    ax_prefix: PrefixSums
    vx_prefix: PrefixSums
    ay_raw: Float[np.ndarray, "n"]  # smoothed IMU ay, uncorrected [m/s²]
    trig: tuple  # the front wheels' geometry terms (_front_terms)
    wheel_vx: Float[np.ndarray, "n 4"]  # [m/s]
    vx: Float[np.ndarray, "n"]  # [m/s]
    spin: Bool[np.ndarray, "n"]
    valid: Bool[np.ndarray, "n"]
    vx_safe: Float[np.ndarray, "n"]  # V_x, NaN where not valid [m/s]
    slip: Float[np.ndarray, "n 4"]
    slip_axle: Float[np.ndarray, "n 2"]
    slip_driven: Float[np.ndarray, "n"]
    driven_wheels: tuple[int, ...] = eqx.field(static=True)


def _motion(stream, vehicle, scales, spin_threshold, thresholds) -> _Motion:
    data = stream.data
    # Channels resampled onto one grid mostly share their gaps: each channel's prefix sums
    # reuse the previous one's counts where the NaN agree.
    last: list[PrefixSums | None] = [None]

    def prefix(name: str) -> PrefixSums:
        last[0] = PrefixSums.of(data[name].to_numpy(dtype=float), like=last[0])
        return last[0]

    def smooth(name: str) -> np.ndarray:
        return prefix(name).window_mean(scales.window // 2)

    omega_raw = _columns(*(data[c].to_numpy(dtype=float) for c in WHEEL_COLUMNS))
    gap = ~np.all(np.isfinite(omega_raw), axis=1)
    omega = nan_moving_average(omega_raw, scales.window)
    yaw = smooth("yaw_rate")
    if "wheel_angle_front" in data:
        steer = smooth("wheel_angle_front")
    else:
        steer = smooth("steering_wheel_angle") / vehicle.steering_ratio
    ax_prefix = prefix("ax")
    ax_raw, ay_raw = ax_prefix.window_mean(scales.window // 2), smooth("ay")

    trig = _front_terms(yaw, steer, ay_raw, vehicle)
    wheel_vx = _wheel_to_vx(omega, yaw, vehicle, trig)
    vx, lock = _vehicle_speed(wheel_vx, vehicle.drive, spin_threshold)
    spin = _spin_check(wheel_vx, vx, vehicle.drive, spin_threshold) | lock
    valid = ~gap & np.isfinite(vx) & (vx > thresholds.min_speed_mps)
    vx_safe = np.where(valid, vx, np.nan)

    slip = _table(vx.shape[0], 4)
    for i in range(4):
        np.subtract(wheel_vx[:, i], vx_safe, out=slip[:, i])
        slip[:, i] /= vx_safe
    slip_axle = _table(vx.shape[0], 2)
    _row_mean(slip, (0, 1), out=slip_axle[:, 0])
    _row_mean(slip, (2, 3), out=slip_axle[:, 1])
    driven_wheels = {"front": (0, 1), "rear": (2, 3), "both": (0, 1, 2, 3)}[vehicle.driven_axle]
    slip_driven = _row_mean(slip, driven_wheels)
    return _Motion(
        omega_raw=omega_raw,
        gap=gap,
        yaw=yaw,
        steer=steer,
        ax_raw=ax_raw,
        ax_prefix=ax_prefix,
        vx_prefix=PrefixSums.of(vx_safe),
        ay_raw=ay_raw,
        trig=trig,
        wheel_vx=wheel_vx,
        vx=vx,
        spin=spin,
        valid=valid,
        vx_safe=vx_safe,
        slip=slip,
        slip_axle=slip_axle,
        slip_driven=slip_driven,
        driven_wheels=driven_wheels,
    )


class _WheelNoise(eqx.Module):
    """Step 2: the wheel signals' noise at the smoothing scale, with the vehicle motion removed."""

    slip_velocity_driven: Float[np.ndarray, "n"]  # driven axle's R·Ω − V_x, unsmoothed [m/s]
    local_wheel: Float[np.ndarray, "n 4"]  # each wheel's slip-velocity noise [m/s]
    slip_sd: Float[np.ndarray, "n 4"]  # [-]
    vx_sd: Float[np.ndarray, "n"]  # [m/s]
    # Prefix sums of the V_x wheels' zero-mean combination (_vx_noise_probe): the noise of
    # the wheel speeds' dV_x/dt (_traction_acceleration) is measured on it too.
    vx_probe: PrefixSums


def _wheel_noise(motion: _Motion, vehicle, scales: _Scales, spin_threshold) -> _WheelNoise:
    # Noise at the smoothing scale, measured on signals with the vehicle motion removed (slip
    # velocities R·Ω − V_x, differences of the V_x wheels), per sample over ~10 s: coloured noise,
    # quantisation and changing road roughness included, unlike a white-noise / √window rule.
    # The probes use the unsmoothed wheel speeds: local_noise_sd applies the smoothing itself.
    m = motion
    # The four slip velocities and the V_x probe in one column-contiguous block: the wheels'
    # V_x are written into it and turned into slip velocities in place.
    probes = np.empty((5, m.vx.shape[0])).T
    wheel_vx_raw = _wheel_to_vx(m.omega_raw, m.yaw, vehicle, m.trig, out=probes[:, :4])
    vx_raw = np.where(
        m.valid, _vehicle_speed(wheel_vx_raw, vehicle.drive, spin_threshold)[0], np.nan
    )
    probes[:, 4] = _vx_noise_probe(wheel_vx_raw, vehicle.drive)
    for i in range(4):
        probes[:, i] -= vx_raw
    slip_velocity_driven = _row_mean(probes, m.driven_wheels)
    vx_probe = PrefixSums.of(probes[:, 4])
    # The slip velocities are NaN where V_x is (not valid): V_x's counts serve them.
    probe_sd = local_noise_sd(
        probes, scales.window, scales.span, like=m.vx_prefix, prefix=(None,) * 4 + (vx_probe,)
    )
    local_wheel = probe_sd[:, :4]
    return _WheelNoise(
        slip_velocity_driven=slip_velocity_driven,
        local_wheel=local_wheel,
        slip_sd=np.divide(local_wheel, m.vx_safe[:, None], out=_table(*local_wheel.shape)),
        vx_sd=probe_sd[:, 4],
        vx_probe=vx_probe,
    )


class _ImuCalibration(eqx.Module):
    """Step 3: the IMU's gain and offsets against the wheel speeds; corrected ax, ay, grade."""

    pitch_gain: float  # squat/dive over-read 1 + g·k [-]
    dvx_dt: Float[np.ndarray, "n"]  # [m/s²]
    imu_gain: ImuGainCorrection
    ax_offset: float  # [m/s²]
    ax_offset_sd: float  # [m/s²]
    ax: Float[np.ndarray, "n"]  # corrected, grade included [m/s²]
    grade: Float[np.ndarray, "n"]  # [rad]
    ay_offset: float  # [m/s²]
    ay: Float[np.ndarray, "n"]  # [m/s²]
    lateral_kin: Float[np.ndarray, "n"]  # V_x · yaw rate [m/s²]
    yaw_acc: Float[np.ndarray, "n"]  # [rad/s²]


def _imu_calibration(
    stream, vehicle, motion: _Motion, scales: _Scales, ax_offset_mps2, ax_gain
) -> _ImuCalibration:
    m, rate = motion, scales.rate_hz
    # IMU offset against the wheel-speed derivative; the corrected ax keeps the road grade.
    # Squat and dive add g·k·a_x to the reading: left in, the forces read 1 + g·k ≈ 2 % high and
    # C_x with them (the model's force gain is centred at 1), and a drive that brakes more than
    # it accelerates would shift the offset.
    pitch_gain = float(body_pitch_gain(vehicle))
    dvx_dt = m.vx_prefix.smoothed_derivative(scales.deriv_window // 2, scales.dt_s)
    ax_smooth_d = m.ax_prefix.window_mean(scales.deriv_window // 2)
    steady = m.valid & ~m.spin & (np.abs(dvx_dt) < 4.0)
    # The IMU's scale factor against the wheel speeds' dV_x/dt (which the pitch over-read is part
    # of): a calibrated IMU is left to the tyre model's force gain, a badly scaled one (a
    # dashcam) would scale every force and C_x with it, so ax is divided by its estimate.
    if ax_gain is None:
        gain, gain_sd = estimate_ax_gain(ax_smooth_d, dvx_dt, steady, rate)
        imu_gain = imu_gain_correction(gain / pitch_gain, gain_sd / pitch_gain)
    else:
        # Given, not estimated: certain, and uncalibrated exactly when it is not 1.
        imu_gain = ImuGainCorrection(
            float(ax_gain), 0.0, float(ax_gain != 1.0), float(ax_gain), 0.0
        )
    ax_raw = m.ax_raw / imu_gain.applied
    ax_smooth_d = ax_smooth_d / imu_gain.applied - (pitch_gain - 1.0) * dvx_dt
    if ax_offset_mps2 is None:
        ax_offset, ax_offset_sd = estimate_ax_offset(ax_smooth_d, dvx_dt, steady, rate)
        if not np.isfinite(ax_offset):
            ax_offset, ax_offset_sd = 0.0, float("nan")
    else:
        ax_offset, ax_offset_sd = float(ax_offset_mps2), 0.0
    ax = (ax_raw - ax_offset) / pitch_gain
    grade = np.arcsin(np.clip((ax_smooth_d - ax_offset - dvx_dt) / GRAVITY_MPS2, -1.0, 1.0))
    if ax_offset_mps2 is None:
        # The offset also holds g·sin(mean grade of this log), which nothing in one log can
        # separate from the mounting pitch: widen its error by the mean grade's uncertainty.
        grade_mean_sd = mean_grade_sd(grade[steady], rate)
        ax_offset_sd = float(np.hypot(ax_offset_sd, GRAVITY_MPS2 * grade_mean_sd))
    lateral_kin = m.vx_safe * m.yaw
    ay_resid = (m.ay_raw - lateral_kin)[m.valid & np.isfinite(m.ay_raw)]
    ay_offset = median(ay_resid) if ay_resid.size else 0.0
    return _ImuCalibration(
        pitch_gain=pitch_gain,
        dvx_dt=dvx_dt,
        imu_gain=imu_gain,
        ax_offset=float(ax_offset),
        ax_offset_sd=float(ax_offset_sd),
        ax=ax,
        grade=grade,
        ay_offset=ay_offset,
        ay=m.ay_raw - ay_offset,
        lateral_kin=lateral_kin,
        yaw_acc=smoothed_derivative(m.yaw, scales.dt_s, scales.deriv_window),
    )


class _Forces(eqx.Module):
    """Step 4: axle forces from the force balance, normalised forces and their noise."""

    resistance: Float[np.ndarray, "n"]  # drag + rolling resistance [N]
    fx_axle: Float[np.ndarray, "n 2"]  # [N]
    fz_axle: Float[np.ndarray, "n 2"]  # [N]
    rho_axle: Float[np.ndarray, "n 2"]
    fx_driven: Float[np.ndarray, "n"]  # [N]
    fz_driven: Float[np.ndarray, "n"]  # [N]
    rho_driven: Float[np.ndarray, "n"]
    rho_driven_sd: Float[np.ndarray, "n"]
    rho_driven_traction: Float[np.ndarray, "n"]
    rho_driven_traction_sd: Float[np.ndarray, "n"]
    rho_total_traction: Float[np.ndarray, "n"]
    load_change_driven: Float[np.ndarray, "n"]  # ΔF_z/F_z,static, traction a_x
    slip_driven_noise: Float[np.ndarray, "n"]  # driven slip-velocity noise [m/s]
    slip_driven_sd: Float[np.ndarray, "n"]
    ax_sd_local: Float[np.ndarray, "n"]  # noise of the smoothed, corrected ax [m/s²]


def _forces(
    stream,
    vehicle,
    motion: _Motion,
    noise: _WheelNoise,
    imu: _ImuCalibration,
    scales: _Scales,
    brake_front_share: float,
) -> _Forces:
    m, window, span = motion, scales.window, scales.span
    ax_traction, ax_traction_sd = _traction_acceleration(
        m.vx_prefix, imu.ax, noise.vx_probe, vehicle.drive, scales.dt_s, window,
        scales.rate_hz, span,
    )  # fmt: skip
    balance = _force_balance(
        vehicle, imu.ax, ax_traction, imu.ay, imu.yaw_acc, m.steer, m.vx, brake_front_share,
    )  # fmt: skip
    resistance, fx_axle, fz_axle = balance.resistance, balance.fx_axle, balance.fz_axle
    no_force = ~(m.valid & np.isfinite(imu.ax))
    for i in range(2):
        fx_axle[no_force, i] = np.nan

    def driven(per_axle: np.ndarray) -> np.ndarray:
        """The driven axle's column, or the sum of both for AWD."""
        if vehicle.driven_axle == "both":
            return per_axle.sum(axis=1)
        return per_axle[:, 0 if vehicle.driven_axle == "front" else 1]

    fx_driven, fz_driven = driven(fx_axle), driven(fz_axle)
    fx_traction, fz_traction = balance.fx_traction, balance.fz_traction
    fx_traction_driven, fz_traction_driven = driven(fx_traction), driven(fz_traction)
    has_traction = m.valid & np.isfinite(ax_traction)
    rho_driven_traction = np.where(has_traction, fx_traction_driven / fz_traction_driven, np.nan)
    rho_total_traction = np.where(
        has_traction,
        (fx_traction[:, 0] + fx_traction[:, 1]) / (fz_traction[:, 0] + fz_traction[:, 1]),
        np.nan,
    )
    static_front, static_rear = (float(v) for v in axle_loads(vehicle, 0.0))
    static_driven = {"front": static_front, "rear": static_rear}.get(
        vehicle.driven_axle, static_front + static_rear
    )
    load_change_driven = np.where(has_traction, fz_traction_driven / static_driven - 1.0, np.nan)
    pushing = rho_total_traction >= 0.0
    velocity = PrefixSums.of(noise.slip_velocity_driven, like=m.vx_prefix)
    slip_driven_noise = local_noise_sd(
        _columns(
            _slip_noise_probe(
                noise.slip_velocity_driven,
                velocity,
                rho_driven_traction * m.vx_safe,
                pushing,
                window,
            ),
            noise.slip_velocity_driven,
        ),
        window,
        span,
        prefix=(None, velocity),
    )
    # Where the tyres brake (no slip window there) the plain slip velocity's noise stands in.
    slip_driven_noise = np.where(
        np.isfinite(slip_driven_noise[:, 0]), slip_driven_noise[:, 0], slip_driven_noise[:, 1]
    )
    # Per-sample noise of the smoothed ax, scaled by the axle's share of m·ax. The offset's
    # uncertainty is common to the whole log and reported apart (nuisances.rho_offset_sd).
    ax_raw = stream.data["ax"].to_numpy(dtype=float)
    ax_sd_local = local_noise_sd(ax_raw, window, span, prefix=m.ax_prefix) / (
        imu.pitch_gain * imu.imu_gain.applied
    )
    fx_total = np.abs(fx_axle[:, 0] + fx_axle[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(fx_total > 0, np.abs(fx_driven) / fx_total, 1.0)
    share = np.clip(np.nan_to_num(share, nan=1.0), 0.0, 1.0)
    return _Forces(
        resistance=resistance,
        fx_axle=fx_axle,
        fz_axle=fz_axle,
        rho_axle=np.divide(fx_axle, fz_axle, out=_table(*fx_axle.shape)),
        fx_driven=fx_driven,
        fz_driven=fz_driven,
        rho_driven=fx_driven / fz_driven,
        rho_driven_sd=vehicle.mass_kg * ax_sd_local * np.maximum(share, 0.5) / fz_driven,
        rho_driven_traction=rho_driven_traction,
        rho_driven_traction_sd=(
            vehicle.mass_kg
            * np.where(np.isfinite(ax_traction_sd), ax_traction_sd, ax_sd_local)
            / fz_traction_driven
        ),
        rho_total_traction=rho_total_traction,
        load_change_driven=load_change_driven,
        slip_driven_noise=slip_driven_noise,
        slip_driven_sd=slip_driven_noise / m.vx_safe,
        ax_sd_local=ax_sd_local,
    )


def _assemble(
    stream,
    vehicle,
    motion: _Motion,
    noise: _WheelNoise,
    imu: _ImuCalibration,
    forces: _Forces,
    scales: _Scales,
    thresholds: SegmentThresholds,
    brake_front_share: float,
) -> StreamFeatures:
    """Step 5: regime labels and the log's nuisances (radius ratios, speed scale), then features."""
    m, f, data, window, rate = motion, forces, stream.data, scales.window, scales.rate_hz
    label = label_samples(
        m.valid,
        f.rho_driven,
        _max_abs_slip(m.slip),
        m.spin,
        imu.lateral_kin,
        thresholds,
    )
    free_straight = (label == FREE_ROLLING) & (np.abs(m.steer) < 0.02)
    radius_ratio, radius_sd, radius_seconds = estimate_radius_ratios(
        m.wheel_vx, free_straight, rate
    )
    if "speed_reference" in data:
        reference = data["speed_reference"].to_numpy(dtype=float)
        ref = PrefixSums.of(reference, like=m.ax_prefix).window_mean(window // 2)
        speed_scale, speed_scale_sd = estimate_speed_scale(m.vx_safe, ref, m.valid, rate)
    else:
        speed_scale, speed_scale_sd = float("nan"), float("nan")
    quant = np.array([stream.quantisation.get(c, 0.0) for c in WHEEL_COLUMNS], dtype=float)
    nuisances = StreamNuisances(
        radius_ratio=radius_ratio,
        radius_ratio_sd=radius_sd,
        radius_ratio_seconds=radius_seconds,
        ax_offset_mps2=imu.ax_offset,
        ax_offset_sd_mps2=imu.ax_offset_sd,
        ax_gain=imu.imu_gain,
        pitch_offset_rad=float(np.arcsin(np.clip(imu.ax_offset / GRAVITY_MPS2, -1, 1))),
        ay_offset_mps2=imu.ay_offset,
        quantisation_radps=quant,
        speed_scale=float(speed_scale),
        speed_scale_sd=float(speed_scale_sd),
        rho_offset_sd=float(vehicle.mass_kg * imu.ax_offset_sd / _summary(f.fz_driven, window)),
        smoothed_noise={
            "vx_mps": float(_summary(noise.vx_sd, window)),
            "slip_velocity_mps": [float(v) for v in _summary(noise.local_wheel, window)],
            "slip_velocity_driven_mps": float(_summary(f.slip_driven_noise, window)),
            "ax_mps2": float(_summary(f.ax_sd_local, window)),
        },
    )
    return StreamFeatures(
        time_s=data["time"].to_numpy(dtype=float),
        vx_mps=m.vx_safe,
        vx_sd_mps=noise.vx_sd,
        wheel_vx_mps=m.wheel_vx,
        slip=m.slip,
        slip_sd=noise.slip_sd,
        slip_axle=m.slip_axle,
        slip_driven=m.slip_driven,
        slip_driven_sd=f.slip_driven_sd,
        fx_axle_n=f.fx_axle,
        fz_axle_n=f.fz_axle,
        rho_axle=f.rho_axle,
        rho_driven=f.rho_driven,
        rho_driven_sd=f.rho_driven_sd,
        rho_driven_traction=f.rho_driven_traction,
        rho_driven_traction_sd=f.rho_driven_traction_sd,
        rho_total_traction=f.rho_total_traction,
        load_change_driven=f.load_change_driven,
        friction_power_w=np.abs(f.fx_driven * m.vx_safe * m.slip_driven),
        ax_mps2=imu.ax,
        ay_mps2=imu.ay,
        dvx_dt_mps2=imu.dvx_dt,
        grade_rad=imu.grade,
        yaw_rate_radps=m.yaw,
        yaw_acc_radps2=imu.yaw_acc,
        steer_rad=m.steer,
        resistance_n=f.resistance,
        label=label,
        valid=m.valid,
        spin=m.spin,
        filled=stream.filled,
        nuisances=nuisances,
        noise=dict(stream.noise),
        sample_rate_hz=float(rate),
        smoothing_s=scales.smoothing_s,
        driven_axle=vehicle.driven_axle,
        vx_source={"fwd": "rear wheels", "rwd": "front wheels", "awd": "median of four wheels"}[
            vehicle.drive
        ],
        brake_front_share=float(brake_front_share),
    )


def _max_abs_slip(slip: np.ndarray) -> np.ndarray:
    """Largest |σ_x| of the four wheels, NaN counted as 0 (``np.nan_to_num`` first, then max)."""
    # fmax skips NaN, so only a row of four NaN stays NaN: that row's 0 comes from nan_to_num.
    largest = np.abs(slip[:, 0])
    wheel = np.empty_like(largest)
    for i in range(1, 4):
        np.fmax(largest, np.abs(slip[:, i], out=wheel), out=largest)
    return np.nan_to_num(largest, nan=0.0, copy=False)


def _summary(x: np.ndarray, window: int) -> float | np.ndarray:
    """Median over the log of a quantity that is smooth over ``window`` samples (NaN ignored).

    Local noise levels and loads change over seconds, so every (window//2)-th sample carries the
    information; the thinned median is the same number at a fraction of the cost on long logs.
    """
    return nanmedian_columns(x[:: max(1, window // 2)])  # all-NaN column: NaN, as documented


def speed_error(
    features: StreamFeatures, reference_mps: Float[np.ndarray, "n"]
) -> dict[str, float]:
    """V_x against a reference speed (GNSS) over valid moving samples.

    Returns
    -------
    dict
        ``mean_mps`` (V_x − ref), ``rms_mps``, ``p95_abs_mps``, ``relative_mean`` (mean of
        V_x/ref − 1, the wheel-radius scale error), ``rms_after_scale_mps`` (after removing that
        scale) and ``samples``.
    """
    ok = features.valid & np.isfinite(reference_mps) & (reference_mps > 3.0)
    ok &= np.isfinite(features.vx_mps)
    if ok.sum() == 0:
        nan = float("nan")
        return dict.fromkeys(
            ("mean_mps", "rms_mps", "p95_abs_mps", "relative_mean", "rms_after_scale_mps"), nan
        ) | {"samples": 0}
    vx, ref = features.vx_mps[ok], reference_mps[ok]
    err = vx - ref
    scale = float(np.mean(vx / ref))
    return {
        "mean_mps": float(err.mean()),
        "rms_mps": float(np.sqrt(np.mean(err**2))),
        "p95_abs_mps": float(np.quantile(np.abs(err), 0.95)),
        "relative_mean": scale - 1.0,
        "rms_after_scale_mps": float(np.sqrt(np.mean((vx / scale - ref) ** 2))),
        "samples": int(ok.sum()),
    }
