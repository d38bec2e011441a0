"""Per-drive tread-wear evidence from one stream: friction work per axle, radius ratio, temperature.

What one drive tells about tread wear (thesis Sec. 4.4):

* **Longitudinal friction work** per axle, W_x = ∫ F_x V_x σ_x dt (eq. 4.19a, 4.25). On the
  driven axle in traction the slip is measured: the wheel speeds' σ_x, corrected for the drive's
  own per-wheel radius ratios (free rolling), times the force balance's F_x. Under braking the
  wheel speeds only see slip relative to the braking free wheels, and the free axle's slip is
  not seen at all, so there the linear slip σ_x = ρ_x / C_x of eq. 4.27 is used with the drive's
  own secant stiffness Ĉ_x = Σ ρ_x² F_z V dt / Σ F_x V σ_x dt over the driven axle's traction
  samples (both axles carry the same tyre model). Its uncertainty: the slip noise of every sample
  (correlated over the smoothing window), and the radius-ratio error, which multiplies the whole
  traction energy ∫ F_x V dt.
* **Braking split**: the features split a braking force by one fixed brake balance (0.7
  front). Coasting in gear is engine drag on the driven wheels alone, and a service brake with
  electronic brake-force distribution follows the axle loads, so the evidence re-splits each
  braking sample's total force: up to :data:`ENGINE_BRAKE_SHARE` of the weight on the driven
  axle(s), the rest in proportion to the axle loads (:func:`braking_split`). With the fixed
  balance the mild decelerations that dominate braking put too little force on the driven front
  axle and too much on the rear; the linear braking work goes with the force squared, so the
  front's braking work read low and the rear's, on the drive-history simulator, well above the
  truth. That was one cause of the evidence reading the simulator's front-axle work at 0.85 of
  the truth; the other remains (``benchmarks/results/wear_history.json``,
  ``evidence_work_over_true``): the radius ratios are read on "free-rolling" samples, chosen by
  the force balance's ρ_x, whose true force the a_x offset's residual hides; the driven wheels'
  slip at that force is read as radius and taken off every traction sample's slip.
* **Lateral friction work** per axle, W_y = ∫ F_y V_x tan α dt (eq. 4.19b) with the axle forces of
  the single-track model (eq. 4.23b, c, from a_y and yaw acceleration; Newton's law holds in
  transients too, so every valid sample counts) and the slip angle of a brush tyre,
  tan α = 3 ρ_y / (c_y (1 + a + a²)), a = (1 − |ρ_y| / μ)^⅓ (the linear α = ρ_y / c_y for
  small ρ_y), with the per-axle cornering stiffness c_y of :class:`CorneringStiffness`: an
  inferred axle stiffness where a lateral posterior exists
  (:func:`tyrebayes.inference.wear.cornering_stiffness_from_lateral`), otherwise the type prior
  :data:`TYPE_PRIOR_CORNERING` (yaw rate and lateral acceleration fix F_y, not the split of
  δ − L ψ̇ / V between the axles' slip angles). W_y scales as 1 / c_y: the stiffness' log-sd is
  carried with the evidence, and the wear fit treats it as the lateral work's scale error.
* **Radius ratio** front / rear (for a front-driven car: driven over non-driven) from straight
  free rolling, with its per-drive standard error: it falls as the driven tyres lose tread (one
  millimetre is about 0.3 % of a 316 mm rolling radius).
* **Speed scale** V_x / GNSS speed where ``speed_reference`` is logged: the free-rolling wheels'
  nominal over true radius, which rises as their tread goes.
* Ambient temperature (median of ``ambient_temperature``) and the driven tyre's temperature
  (lumped heat balance, :func:`~tyrebayes.streams.tyre_temperature.features_tyre_temperature`),
  weighted by friction power.
* Distance (∫ V_x dt over the valid samples) and the odometer at the start of the drive, from an
  optional extra ``odometer`` column [m]: with it, a history of logged drives stands for the
  distance driven between them.

:class:`DriveWearEvidence` holds one drive's numbers; :meth:`DriveWearEvidence.row` flattens it to
the columns of :data:`WEAR_EVIDENCE_COLUMNS` (the fleet-run drive summary table carries them).

Examples
--------
>>> from tyrebayes._resources import data_dir
>>> from tyrebayes._domain import load_vehicle
>>> from tyrebayes.streams import read_stream, validate_stream
>>> vehicle = load_vehicle("suv_rav4")
>>> stream = validate_stream(read_stream(data_dir() / "comma2k19_rav4_segment.csv"), vehicle)
>>> ev = drive_wear_evidence(stream, vehicle)
>>> 0.5 < ev.distance_km < 2.0
True
"""

from __future__ import annotations

from pathlib import Path

import equinox as eqx
import numpy as np
import pandas as pd

from ..physics.vehicle import GRAVITY_MPS2, Vehicle
from .features import StreamFeatures, compute_features
from .order_stats import nanmedian
from .tyre_temperature import features_tyre_temperature
from .validate import ValidatedStream

#: Columns of :meth:`DriveWearEvidence.row`, in order (units in the names; ``_sd`` = 1-sigma).
WEAR_EVIDENCE_COLUMNS: tuple[str, ...] = (
    "duration_s",
    "distance_km",
    "odometer_start_km",
    "work_x_front_j",
    "work_x_front_sd_j",
    "work_x_rear_j",
    "work_x_rear_sd_j",
    "work_y_front_j",
    "work_y_rear_j",
    "cornering_stiffness_front_per_rad",
    "cornering_stiffness_rear_per_rad",
    "cornering_stiffness_log_sd",
    "secant_stiffness",
    "radius_ratio_front_rear",
    "radius_ratio_front_rear_sd",
    "free_rolling_s",
    "speed_scale",
    "speed_scale_sd",
    "ambient_c",
    "tyre_temperature_c",
)

#: Coasting in gear brakes the driven wheels with the engine's drag, up to this share of the
#: weight (0.05 g, about 0.5 m/s²: a petrol car's deceleration in gear with the throttle shut).
ENGINE_BRAKE_SHARE = 0.05
#: Friction coefficient of the brush slip angle [-]: the dry-road median of the package's μ prior
#: (:data:`tyrebayes.inference.surface_friction.MU_MEDIAN`); it only bends α where |ρ_y| nears μ.
LATERAL_MU = 1.0


class CorneringStiffness(eqx.Module):
    """Per-axle cornering stiffness over axle load used for the lateral slip angle.

    Attributes
    ----------
    front_per_rad, rear_per_rad : float
        c_y of the front and rear axle [1/rad] (median).
    log_sd : float
        Their uncertainty as a log-sd [-]; the wear fit carries it as the scale error of the
        lateral work (W_y ∝ 1 / c_y).
    source : str
        ``"lateral_fit"`` (an inferred axle stiffness), ``"type_prior"`` or ``"given"``.

    Examples
    --------
    >>> CorneringStiffness(18.0, 20.0, 0.1, "given").rear_per_rad
    20.0
    """

    front_per_rad: float
    rear_per_rad: float
    log_sd: float
    source: str = eqx.field(static=True, default="given")

    def __check_init__(self):
        for name in ("front_per_rad", "rear_per_rad"):
            value = float(getattr(self, name))
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"CorneringStiffness.{name}: expected > 0 [1/rad], got {value}")
        if not (np.isfinite(self.log_sd) and self.log_sd >= 0):
            raise ValueError(f"CorneringStiffness.log_sd: expected >= 0, got {self.log_sd}")

    @property
    def per_axle(self) -> np.ndarray:
        """(front, rear) [1/rad]."""
        return np.array([self.front_per_rad, self.rear_per_rad], dtype=float)


#: c_y where no lateral posterior exists: the median of the measured car and SUV tyres'
#: K_y / F_z at nominal load (16.5 /rad, the lateral model's prior median,
#: :class:`tyrebayes.inference.lateral.model.LateralPriors`) with that prior's log-sd 0.5 (an
#: axle's value includes compliance steer, load and pressure).
TYPE_PRIOR_CORNERING = CorneringStiffness(16.5, 16.5, 0.5, "type_prior")
#: Ambient temperature assumed for the tyre-temperature estimate of a stream without an
#: ``ambient_temperature`` column [°C]; the evidence then reports ``ambient_c`` as NaN.
FALLBACK_AMBIENT_C = 15.0


class DriveWearEvidence(eqx.Module):
    """One drive's tread-wear evidence (module docstring). Axles are (front, rear).

    Attributes
    ----------
    duration_s : float
        Length of the stream [s].
    distance_km : float
        ∫ V_x dt over the valid samples [km].
    odometer_start_km : float
        Odometer at the drive's start [km] (NaN without an ``odometer`` column).
    work_x_j, work_x_sd_j : ndarray, shape (2,)
        Longitudinal friction work of each axle (both wheels) [J] and its standard error.
    work_y_j : ndarray, shape (2,)
        Lateral friction work of each axle [J] (0 where no sample was usable).
    cornering : CorneringStiffness
        The c_y behind ``work_y_j`` and where it came from.
    secant_stiffness : float
        The drive's Ĉ_x used for the linear-slip parts [-] (NaN: no traction samples; then the
        work is the measured traction part only and its sd says so).
    radius_ratio_front_rear, radius_ratio_front_rear_sd : float
        Mean rolling radius of the front wheels over the rear ones [-] and its standard error.
    free_rolling_s : float
        Seconds of straight free rolling behind the radius ratio.
    speed_scale, speed_scale_sd : float
        V_x / speed_reference [-] and its standard error (NaN without a reference).
    ambient_c : float
        Median ambient temperature [°C] (NaN without an ambient column).
    tyre_temperature_c : float
        Friction-power weighted mean temperature of the driven tyres [°C].

    Examples
    --------
    From :func:`drive_wear_evidence` on the shipped one-minute RAV4 segment:

    >>> from tyrebayes import load_vehicle, read_stream, validate_stream
    >>> from tyrebayes._resources import data_dir
    >>> vehicle = load_vehicle("suv_rav4")
    >>> stream = validate_stream(read_stream(data_dir() / "comma2k19_rav4_segment.csv"), vehicle)
    >>> evidence = drive_wear_evidence(stream, vehicle)
    >>> round(evidence.duration_s), round(evidence.distance_km, 2), evidence.work_x_j.shape
    (60, 1.0, (2,))
    >>> row = evidence.row()
    >>> sorted(row) == sorted(WEAR_EVIDENCE_COLUMNS)
    True
    """

    duration_s: float
    distance_km: float
    odometer_start_km: float
    work_x_j: np.ndarray
    work_x_sd_j: np.ndarray
    work_y_j: np.ndarray
    cornering: CorneringStiffness
    secant_stiffness: float
    radius_ratio_front_rear: float
    radius_ratio_front_rear_sd: float
    free_rolling_s: float
    speed_scale: float
    speed_scale_sd: float
    ambient_c: float
    tyre_temperature_c: float

    def row(self) -> dict[str, float]:
        """The evidence as one flat row: :data:`WEAR_EVIDENCE_COLUMNS` to floats."""
        return {
            "duration_s": float(self.duration_s),
            "distance_km": float(self.distance_km),
            "odometer_start_km": float(self.odometer_start_km),
            "work_x_front_j": float(self.work_x_j[0]),
            "work_x_front_sd_j": float(self.work_x_sd_j[0]),
            "work_x_rear_j": float(self.work_x_j[1]),
            "work_x_rear_sd_j": float(self.work_x_sd_j[1]),
            "work_y_front_j": float(self.work_y_j[0]),
            "work_y_rear_j": float(self.work_y_j[1]),
            "cornering_stiffness_front_per_rad": float(self.cornering.front_per_rad),
            "cornering_stiffness_rear_per_rad": float(self.cornering.rear_per_rad),
            "cornering_stiffness_log_sd": float(self.cornering.log_sd),
            "secant_stiffness": float(self.secant_stiffness),
            "radius_ratio_front_rear": float(self.radius_ratio_front_rear),
            "radius_ratio_front_rear_sd": float(self.radius_ratio_front_rear_sd),
            "free_rolling_s": float(self.free_rolling_s),
            "speed_scale": float(self.speed_scale),
            "speed_scale_sd": float(self.speed_scale_sd),
            "ambient_c": float(self.ambient_c),
            "tyre_temperature_c": float(self.tyre_temperature_c),
        }


def _free_slip_ratios(
    feats: StreamFeatures,
    driven: list[int],
    c_hat: float,
    free_force: dict[int, float] | None = None,
) -> np.ndarray:
    """Per-wheel radius ratios with the driven wheels' free-rolling slip taken out.

    "Free rolling" (|ρ_x| < 0.02 on the driven axle) still pushes against drag and rolling
    resistance, so the driven wheels turn faster by σ ≈ ρ_x / C_x there: the free-rolling ratio
    reads that slip as radius. Divided out with the drive's secant stiffness (eq. 4.27).
    ``free_force``: :func:`_free_rolling_force` of ``feats``, when the caller has it (it does
    not change with Ĉ_x, which :func:`drive_wear_evidence` iterates on).
    """
    ratio = np.asarray(feats.nuisances.radius_ratio, dtype=float).copy()
    if not (np.all(np.isfinite(ratio)) and np.isfinite(c_hat)):
        return ratio
    if free_force is None:
        free_force = _free_rolling_force(feats, driven)
    for axle in driven:
        ratio[2 * axle : 2 * axle + 2] /= 1.0 + np.nan_to_num(free_force[axle]) / c_hat
    return ratio


def _free_rolling_force(feats: StreamFeatures, driven: list[int]) -> dict[int, float]:
    """Mean ρ_x of each driven axle over the straight free-rolling samples.

    0 without such samples, NaN when none has a force (:func:`_free_slip_ratios` counts that
    as 0 too); found once per drive, also where the ratios turn out not to need it, so an
    all-NaN axle gives NaN without ``np.nanmean``'s warning.
    """
    free = feats.mask("free_rolling") & (np.abs(feats.steer_rad) < 0.02)
    rho = feats.rho_axle[free]
    if not rho.size:
        return dict.fromkeys(driven, 0.0)
    return {
        axle: float(np.nanmean(rho[:, axle])) if np.isfinite(rho[:, axle]).any() else np.nan
        for axle in driven
    }


def _corrected_slip(feats: StreamFeatures, ratio: np.ndarray, drive: str) -> np.ndarray:
    """Per-wheel slip with the drive's own radius ratios removed (NaN ratios: nominal radii).

    A wheel of true radius r_i R_nom reads wheel_vx_i = (1 + σ_i) V r_ref / r_i, where r_ref is
    the mean ratio of the wheels V_x comes from; hence σ_i = (1 + slip_i) r_i / r_ref − 1.
    """
    scale = _slip_scale(ratio, drive)
    if scale is None:
        return feats.slip
    return (1.0 + feats.slip) * scale[None, :] - 1.0


def _slip_scale(ratio: np.ndarray, drive: str) -> np.ndarray | None:
    """r_i / r_ref of :func:`_corrected_slip`, or None for nominal radii (a NaN ratio)."""
    if not np.all(np.isfinite(ratio)):
        return None
    ref = {"fwd": (2, 3), "rwd": (0, 1)}.get(drive, (0, 1, 2, 3))
    return ratio / float(np.mean(ratio[list(ref)]))


def _corrected_slip_axle(feats: StreamFeatures, ratio: np.ndarray, drive: str) -> np.ndarray:
    """Per-axle slip, (n, 2): the mean of its wheels' :func:`_corrected_slip`.

    An axle's slip is (σ_a + σ_b) / 2 (what ndarray.mean gives for two), formed column by
    column in the axle table itself with the same arithmetic as the (n, 4) table of σ_i: the
    same numbers without its three temporaries of the whole table (four times a drive).
    """
    slip = feats.slip
    scale = _slip_scale(ratio, drive)
    out = np.empty((2, slip.shape[0])).T  # columns contiguous, like the features' tables
    other = np.empty(slip.shape[0])
    for axle, wheels in enumerate(((0, 1), (2, 3))):
        for wheel, target in zip(wheels, (out[:, axle], other), strict=True):
            if scale is None:
                np.copyto(target, slip[:, wheel])
            else:
                np.add(slip[:, wheel], 1.0, out=target)
                target *= scale[wheel]
                target -= 1.0
        out[:, axle] += other
    out /= 2.0
    return out


def _front_rear_ratio(ratio: np.ndarray, sd: np.ndarray) -> tuple[float, float]:
    front, rear = ratio[:2].mean(), ratio[2:].mean()
    # the four ratios share one normalisation; their errors are treated as independent
    value = front / rear
    value_sd = value * np.hypot(
        np.hypot(sd[0], sd[1]) / 2 / front, np.hypot(sd[2], sd[3]) / 2 / rear
    )
    return float(value), float(value_sd)


def braking_split(fx_axle_n: np.ndarray, fz_axle_n: np.ndarray, vehicle: Vehicle) -> np.ndarray:
    """Axle forces (n, 2) [N] with each braking sample's total re-split (module docstring).

    Where F_x,front + F_x,rear < 0: engine drag up to :data:`ENGINE_BRAKE_SHARE` m g on the
    driven axle(s) (split as the drive splits traction), the rest of the braking force in
    proportion to the axle loads (ideal, EBD-like distribution). Traction samples and NaN are
    kept as they are.

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> car = load_vehicle("compact_fwd")
    >>> fx = braking_split(np.array([[-700.0, -300.0]]), np.array([[8000.0, 6000.0]]), car)
    >>> bool(fx[0, 0] < -700.0), float(fx.sum())
    (True, -1000.0)
    """
    fx = np.asarray(fx_axle_n, dtype=float)
    fz = np.asarray(fz_axle_n, dtype=float)
    total = fx[:, 0] + fx[:, 1]
    with np.errstate(invalid="ignore"):
        braking = total < 0.0
        engine = np.clip(total, -ENGINE_BRAKE_SHARE * vehicle.mass_kg * GRAVITY_MPS2, 0.0)
        load_share = fz[:, 0] / (fz[:, 0] + fz[:, 1])
    front = vehicle.traction_front_share * engine + load_share * (total - engine)
    split = np.column_stack([front, total - front])
    return np.where(braking[:, None], split, fx)


def brush_slip_angle(rho_y: np.ndarray, c_y_per_rad, mu: float = LATERAL_MU) -> np.ndarray:
    """tan α of a brush tyre at normalised lateral force ρ_y = F_y / F_z (module docstring).

    ``c_y_per_rad`` broadcasts against ``rho_y`` (e.g. shape (2,) for (n, 2) axle forces);
    |ρ_y| is held below 0.97 μ (beyond the peak the slip is not defined by the force).

    Examples
    --------
    >>> t = brush_slip_angle(np.array([0.01, 0.5]), 16.5)
    >>> bool(abs(t[0] / (0.01 / 16.5) - 1) < 0.01), bool(t[1] > 0.5 / 16.5)
    (True, True)
    """
    rho = np.clip(np.asarray(rho_y, dtype=float), -0.97 * mu, 0.97 * mu)
    a = np.cbrt(1.0 - np.abs(rho) / mu)
    return 3.0 * rho / (np.asarray(c_y_per_rad, dtype=float) * (1.0 + a + a * a))


class _WorkTerms(eqx.Module):
    """What :func:`_longitudinal_work` needs that does not change with the radius ratios.

    Per sample and axle, shape (n, 2): ``power_w`` F_x V [W] (NaN where F_x is), ``usable``
    (valid, finite F_x, no spin), ``pushing`` (F_x > 0 on a driven axle), ``slip_sd`` [-],
    ``kernel_j`` ρ² F_z |V| dt [J], not yet masked.
    """

    power_w: np.ndarray
    usable: np.ndarray
    pushing: np.ndarray
    slip_sd: np.ndarray
    kernel_j: np.ndarray


def _work_terms(feats, fx, is_driven, valid, dt) -> _WorkTerms:
    vx = feats.vx_mps
    fz = feats.fz_axle_n
    slip_axle_sd = np.column_stack(
        [
            np.hypot(feats.slip_sd[:, 0], feats.slip_sd[:, 1]) / 2,
            np.hypot(feats.slip_sd[:, 2], feats.slip_sd[:, 3]) / 2,
        ]
    )
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return _WorkTerms(
            power_w=fx * vx[:, None],
            usable=valid[:, None] & np.isfinite(fx) & ~feats.spin[:, None],
            pushing=(fx > 0) & is_driven[None, :],
            slip_sd=slip_axle_sd,
            kernel_j=(fx / fz) ** 2 * fz * np.abs(vx)[:, None] * dt,
        )


class _MaskedSums(eqx.Module):
    """The sums of :func:`_longitudinal_work` that depend on the usable samples, not the slip.

    ``use`` (n, 2) the usable samples, ``traction`` (n, 2) those pushing on a driven axle,
    ``power_w`` (n, 2) F_x V there [W] (0 elsewhere), ``kernel_j`` (n, 2) ρ² F_z |V| dt there
    [J]; per axle ``noise_var_j2`` [J²], ``traction_energy_j`` [J], ``linear_kernel_j`` [J]
    (the kernel of usable samples that do not push), and ``traction_kernel_j`` [J] in all.
    """

    use: np.ndarray
    traction: np.ndarray
    power_w: np.ndarray
    kernel_j: np.ndarray
    noise_var_j2: np.ndarray
    traction_energy_j: np.ndarray
    linear_kernel_j: np.ndarray
    traction_kernel_j: float


def _masked_sums(feats, terms: _WorkTerms, use: np.ndarray, dt: float) -> _MaskedSums:
    traction = use & terms.pushing
    power = np.where(use, terms.power_w, 0.0)  # F_x V [W]
    # Slip noise is correlated over the smoothing window: a sum of n samples has the variance
    # of n / window independent ones, each window-fold larger.
    window = max(1.0, feats.smoothing_s * feats.sample_rate_hz)
    noise_var = np.where(traction, (power * terms.slip_sd) ** 2, 0.0).sum(axis=0) * dt**2 * window
    kernel = np.where(use, terms.kernel_j, 0.0)
    return _MaskedSums(
        use=use,
        traction=traction,
        power_w=power,
        kernel_j=kernel,
        noise_var_j2=noise_var,
        traction_energy_j=np.where(traction, power, 0.0).sum(axis=0) * dt,
        linear_kernel_j=np.where(use & ~traction, kernel, 0.0).sum(axis=0),
        traction_kernel_j=np.where(traction, kernel, 0.0).sum(),
    )


def _longitudinal_work(feats, ratios, ratio_sd4, drive, terms: _WorkTerms, dt, sums=None):
    """(work [J], its sd, Ĉ_x, per-sample kernel ρ² F_z V dt (n, 2), usable mask (n, 2), sums).

    Only the slip changes with the radius ratios; the rest comes from ``terms``, computed once
    for the iteration over ratios in :func:`drive_wear_evidence`, and from ``sums`` (the
    previous iteration's :class:`_MaskedSums`), reused while the usable samples are the same.
    """
    slip_axle = _corrected_slip_axle(feats, ratios, drive)
    use = terms.usable & np.isfinite(slip_axle)
    if sums is None or not np.array_equal(sums.use, use):
        sums = _masked_sums(feats, terms, use, dt)
    measured = np.where(sums.traction, sums.power_w * slip_axle, 0.0).sum(axis=0) * dt
    noise_var, traction_kernel = sums.noise_var_j2, sums.traction_kernel_j
    _, ratio_sd = _front_rear_ratio(ratios, ratio_sd4)
    ratio_sd = ratio_sd if np.isfinite(ratio_sd) else 2e-3  # nominal radii: ~0.2 % unknown
    offset_var = (sums.traction_energy_j * ratio_sd) ** 2
    measured_total = float(measured.sum())
    measured_sd = float(np.sqrt(noise_var.sum() + offset_var.sum()))
    if measured_total > 0 and traction_kernel > 0:
        c_hat = float(traction_kernel / measured_total)
        rel_sd = measured_sd / measured_total
    else:
        c_hat, rel_sd = float("nan"), float("nan")
    linear_part = sums.linear_kernel_j
    linear = linear_part / c_hat if np.isfinite(c_hat) else np.zeros(2)
    work_x = measured + linear
    work_x_sd = np.sqrt(noise_var + offset_var + (linear * np.nan_to_num(rel_sd)) ** 2)
    return work_x, work_x_sd, c_hat, sums.kernel_j, use, sums


def drive_wear_evidence(
    stream: ValidatedStream,
    vehicle: Vehicle,
    *,
    features: StreamFeatures | None = None,
    cornering: CorneringStiffness | None = None,
) -> DriveWearEvidence:
    """Tread-wear evidence of one drive (thesis eq. 4.19, 4.25, 4.27; module docstring).

    Parameters
    ----------
    stream : ValidatedStream
        From :func:`tyrebayes.streams.validate_stream`.
    vehicle : Vehicle
        The car (nominal radius, geometry, drive).
    features : StreamFeatures, optional
        Features already computed from ``stream`` with ``vehicle``
        (:func:`~tyrebayes.streams.compute_features`); computed here otherwise.
    cornering : CorneringStiffness, optional
        Per-axle c_y for the lateral slip angle: an inferred axle stiffness
        (:func:`tyrebayes.inference.wear.cornering_stiffness_from_lateral`); default
        :data:`TYPE_PRIOR_CORNERING`. The evidence records which was used.

    Returns
    -------
    DriveWearEvidence

    Examples
    --------
    >>> from tyrebayes import load_vehicle, read_stream, validate_stream
    >>> from tyrebayes._resources import data_dir
    >>> vehicle = load_vehicle("suv_rav4")
    >>> stream = validate_stream(read_stream(data_dir() / "comma2k19_rav4_segment.csv"), vehicle)
    >>> evidence = drive_wear_evidence(stream, vehicle)
    >>> evidence.cornering.source, bool(evidence.work_x_j.sum() > 0)
    ('type_prior', True)
    """
    cornering = TYPE_PRIOR_CORNERING if cornering is None else cornering
    if not isinstance(cornering, CorneringStiffness):
        raise TypeError(f"cornering: expected a CorneringStiffness, got {type(cornering).__name__}")
    feats = compute_features(stream, vehicle) if features is None else features
    data = stream.data
    dt = 1.0 / feats.sample_rate_hz
    vx = feats.vx_mps
    valid = feats.valid & np.isfinite(vx)
    distance_km = float(np.sum(np.where(valid, vx, 0.0)) * dt / 1000.0)
    duration_s = float(feats.time_s[-1] - feats.time_s[0])
    odometer = data["odometer"].to_numpy(dtype=float) if "odometer" in data else np.array([np.nan])
    finite_odo = odometer[np.isfinite(odometer)]
    odometer_start_km = float(finite_odo[0] / 1000.0) if finite_odo.size else float("nan")

    # --- longitudinal work (iterated: the radius ratios need Ĉ_x, Ĉ_x needs the slip)
    fz = feats.fz_axle_n
    driven = {"front": [0], "rear": [1], "both": [0, 1]}[vehicle.driven_axle]
    is_driven = np.zeros(2, dtype=bool)
    is_driven[driven] = True
    ratio_sd4 = np.asarray(feats.nuisances.radius_ratio_sd, dtype=float)
    c_hat = float("nan")
    fx_axle = braking_split(feats.fx_axle_n, fz, vehicle)
    terms, sums = _work_terms(feats, fx_axle, is_driven, valid, dt), None
    free_force = _free_rolling_force(feats, driven)
    for _ in range(4):
        ratios = _free_slip_ratios(feats, driven, c_hat, free_force)
        work = _longitudinal_work(feats, ratios, ratio_sd4, vehicle.drive, terms, dt, sums)
        c_hat, sums = work[2], work[5]
    work_x, work_x_sd, c_hat, kernel, use, _ = work

    # --- lateral work (single track, eq. 4.23b, c; brush slip angle with the axles' c_y)
    # a_y = V_x ψ̇ (quasi-steady: v̇_y neglected): the gyro's noise is a small fraction of the
    # accelerometer's, and noise squared in ρ_y² would read as lateral work on straight roads
    ay = vx * feats.yaw_rate_radps
    yaw_acc = feats.yaw_acc_radps2
    usable_y = valid & np.isfinite(ay) & np.isfinite(yaw_acc)
    lf, lr = vehicle.cog_to_front_axle_m, vehicle.wheelbase_m - vehicle.cog_to_front_axle_m
    fy_front = (
        vehicle.mass_kg * ay * lr + vehicle.yaw_inertia_kgm2 * yaw_acc
    ) / vehicle.wheelbase_m
    fy_rear = (vehicle.mass_kg * ay * lf - vehicle.yaw_inertia_kgm2 * yaw_acc) / vehicle.wheelbase_m
    fy = np.column_stack([fy_front, fy_rear])
    with np.errstate(invalid="ignore", divide="ignore"):
        tan_alpha = brush_slip_angle(fy / fz, cornering.per_axle[None, :])
        power_y = np.abs(fy * vx[:, None] * tan_alpha)
    ok_y = usable_y[:, None] & np.isfinite(power_y)
    work_y = np.where(ok_y, power_y, 0.0).sum(0) * dt

    # --- radius ratio, speed scale, temperatures
    ratio, ratio_sd_raw = _front_rear_ratio(ratios, ratio_sd4)
    ambient = (
        data["ambient_temperature"].to_numpy(dtype=float)
        if "ambient_temperature" in data
        else np.array([np.nan])
    )
    ambient_c = nanmedian(ambient) if np.any(np.isfinite(ambient)) else float("nan")
    temp = features_tyre_temperature(
        feats, ambient_c=ambient_c if np.isfinite(ambient_c) else FALLBACK_AMBIENT_C
    )
    weight = np.where(use, kernel, 0.0).sum(axis=1)
    ok = np.isfinite(temp) & (weight > 0)
    tyre_temp = (
        float(np.sum(weight[ok] * temp[ok]) / np.sum(weight[ok]))
        if ok.any()
        else float(np.nanmean(temp))
    )
    return DriveWearEvidence(
        duration_s=duration_s,
        distance_km=distance_km,
        odometer_start_km=odometer_start_km,
        work_x_j=np.asarray(work_x, dtype=float),
        work_x_sd_j=np.asarray(work_x_sd, dtype=float),
        work_y_j=np.asarray(work_y, dtype=float),
        cornering=cornering,
        secant_stiffness=c_hat,
        radius_ratio_front_rear=ratio,
        radius_ratio_front_rear_sd=ratio_sd_raw,
        free_rolling_s=float(feats.nuisances.radius_ratio_seconds),
        speed_scale=float(feats.nuisances.speed_scale),
        speed_scale_sd=float(feats.nuisances.speed_scale_sd),
        ambient_c=ambient_c,
        tyre_temperature_c=tyre_temp,
    )


def wear_evidence_table(
    paths, vehicle: Vehicle, vehicle_name: str = "", cornering: CorneringStiffness | None = None
) -> pd.DataFrame:
    """Tread-wear evidence of several stream files, one row per drive, in the given order.

    Parameters
    ----------
    paths : sequence of path-like
        Stream files (:func:`tyrebayes.streams.read_stream`), in driving order.
    vehicle : Vehicle
        The car that drove them.
    vehicle_name : str
        Written to the ``vehicle`` column.
    cornering : CorneringStiffness, optional
        Per-axle c_y of the car's tyres (default :data:`TYPE_PRIOR_CORNERING`); its ``source``
        goes to the ``cornering_stiffness_source`` column.

    Returns
    -------
    pandas.DataFrame
        :func:`drive_wear_evidence`'s row per drive, with ``drive_id`` (file stem), ``vehicle``,
        ``drive_order`` and ``cornering_stiffness_source`` columns added (the fleet-run summary
        table's layout).

    Examples
    --------
    >>> from tyrebayes import load_vehicle
    >>> from tyrebayes._resources import data_dir
    >>> path = data_dir() / "comma2k19_rav4_segment.csv"
    >>> table = wear_evidence_table([path, path], load_vehicle("suv_rav4"), "suv_rav4")
    >>> table[["drive_id", "drive_order", "cornering_stiffness_source"]].values.tolist()
    [['comma2k19_rav4_segment', 0, 'type_prior'], ['comma2k19_rav4_segment', 1, 'type_prior']]
    """
    from .io import read_stream
    from .validate import validate_stream

    rows = []
    for order, path in enumerate(paths):
        stream = validate_stream(read_stream(path), vehicle)
        rows.append(
            {
                "drive_id": Path(path).stem,
                "vehicle": vehicle_name,
                "drive_order": order,
                **(ev := drive_wear_evidence(stream, vehicle, cornering=cornering)).row(),
                "cornering_stiffness_source": ev.cornering.source,
            }
        )
    return pd.DataFrame(rows)
