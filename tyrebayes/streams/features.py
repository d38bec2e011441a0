"""The signal pipeline: a validated stream to per-sample tyre features with noise levels.

Steps (thesis chapter 4.3):

1. Smooth the channels with a short NaN-aware moving average (``smoothing_s``).
2. Translate each wheel's speed R·Ω to the vehicle's longitudinal speed (curve compensation with
   yaw rate and road-wheel angle). Eq. 4.23 takes the body's sideslip β = 0; the steered
   wheels' speeds are read here with the single-track model's steady-state V_y instead
   (:func:`~tyrebayes.streams.motion._front_terms`), which in a tight low-speed turn is worth
   1-2 % of slip.
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

import equinox as eqx
import numpy as np
from jaxtyping import Bool, Float, Int

from ..internal.renamed import renamed_keyword
from ..physics.vehicle import GRAVITY_MPS2, Vehicle
from .axle_forces import _Forces, _forces
from .filters import PrefixSums
from .imu_calibration import _imu_calibration, _ImuCalibration
from .motion import REAR_CORNERING_PER_RAD as REAR_CORNERING_PER_RAD
from .motion import _Motion, _motion, _Scales
from .nuisances import StreamNuisances, estimate_radius_ratios, estimate_speed_scale
from .order_stats import nanmedian_columns
from .schema import WHEEL_COLUMNS
from .segments import (
    DEFAULT_THRESHOLDS,
    FREE_ROLLING,
    SEGMENT_REGIMES,
    SegmentThresholds,
    label_samples,
    summarize_segments,
)
from .validate import ValidatedStream
from .wheel_noise import _wheel_noise, _WheelNoise


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
        where V_x comes from free-rolling wheels
        (:func:`~tyrebayes.streams.axle_forces._traction_acceleration`)
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
    label : index into :data:`SEGMENT_REGIMES`
    valid : V_x usable (moving, no gap)
    spin : spin/lock check fired (chapter 4.3.2)
    filled : sample bridged over a dropped sample
    nuisances : :class:`StreamNuisances`
    noise : per raw channel, white-noise sd [channel unit]
    sample_rate_hz, smoothing_s, driven_axle, vx_source, brake_front_share : metadata

    Examples
    --------
    >>> from tyrebayes import load_vehicle, read_stream, validate_stream
    >>> from tyrebayes._resources import data_dir
    >>> vehicle = load_vehicle("suv_rav4")
    >>> df = read_stream(data_dir() / "comma2k19_rav4_segment.csv")
    >>> feats = compute_features(validate_stream(df, vehicle), vehicle)
    >>> feats.driven_axle, feats.vx_source, feats.slip.shape
    ('front', 'rear wheels', (5352, 4))
    >>> sorted(feats.segments())[:3]
    ['braking', 'cornering', 'free_rolling']
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

    @renamed_keyword("kind", "regime", what="a segment label of SEGMENT_REGIMES")
    def mask(self, regime: str) -> Bool[np.ndarray, "n"]:
        """Samples labelled with the driving regime ``regime`` (one of :data:`SEGMENT_REGIMES`)."""
        if regime not in SEGMENT_REGIMES:
            raise ValueError(f"mask: expected one of {SEGMENT_REGIMES}, got {regime!r}")
        return self.label == SEGMENT_REGIMES.index(regime)


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
    A chain of named steps, each returning a small Module, one module each:
    :mod:`~tyrebayes.streams.motion` (smoothed channels, wheel speeds as V_x, vehicle speed,
    slips; thesis ch. 4.3), :mod:`~tyrebayes.streams.wheel_noise` (noise at the smoothing
    scale), :mod:`~tyrebayes.streams.imu_calibration` (IMU gain, offsets, grade),
    :mod:`~tyrebayes.streams.axle_forces` (force balance, eqs. 4.22/4.23, normalised forces and
    their noise) and :func:`_assemble` here (regime labels, nuisances).

    Examples
    --------
    >>> from tyrebayes import load_vehicle, read_stream, validate_stream
    >>> from tyrebayes._resources import data_dir
    >>> vehicle = load_vehicle("suv_rav4")
    >>> stream = validate_stream(read_stream(data_dir() / "comma2k19_rav4_segment.csv"), vehicle)
    >>> feats = compute_features(stream, vehicle, smoothing_s=0.5)
    >>> feats.smoothing_s, bool(feats.valid.all())
    (0.5, True)
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
    m, f, data, rate = motion, forces, stream.data, scales.rate_hz
    label = label_samples(
        m.valid,
        f.rho_driven,
        _max_abs_slip(m.slip),
        m.spin,
        imu.lateral_kin,
        thresholds,
    )
    nuisances = _nuisances(stream, vehicle, m, noise, imu, f, scales, label)
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


def _nuisances(
    stream,
    vehicle,
    m: _Motion,
    noise: _WheelNoise,
    imu: _ImuCalibration,
    f: _Forces,
    scales: _Scales,
    label: np.ndarray,
) -> StreamNuisances:
    """The log's nuisances: radius ratios on free straight rolling, the speed scale against a
    reference speed, the IMU's offsets and gain, the noise levels at the smoothing scale."""
    data, window, rate = stream.data, scales.window, scales.rate_hz
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
    return StreamNuisances(
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
