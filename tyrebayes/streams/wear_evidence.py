"""Per-drive tread-wear evidence from one stream: friction work per axle, radius ratio, temperature.

What one drive tells about tread wear (thesis Sec. 4.4):

* **Longitudinal friction work** per axle, W_x = ∫ F_x V_x σ_x dt (eq. 4.19a, 4.25), with each
  braking sample's force re-split between the axles: :mod:`tyrebayes.streams.longitudinal_work`.
* **Lateral friction work** per axle, W_y = ∫ F_y V_x tan α dt (eq. 4.19b), with the per-axle
  cornering stiffness of :class:`~tyrebayes.streams.cornering_stiffness.CorneringStiffness`:
  :mod:`tyrebayes.streams.lateral_work`.
* **Radius ratio** front / rear (for a front-driven car: driven over non-driven) from straight
  free rolling, with its per-drive standard error: it falls as the driven tyres lose tread (one
  millimetre is about 0.3 % of a 316 mm rolling radius).
* **Speed scale** V_x / GNSS speed where ``speed_reference`` is logged: the free-rolling wheels'
  nominal over true radius, which rises as their tread goes.
* Ambient temperature (median of ``ambient_temperature``) and the tyres' temperature (lumped
  heat balance, :func:`~tyrebayes.streams.tyre_temperature.driven_tyre_temperature`): the driven
  tyres' (:func:`~tyrebayes.streams.tyre_temperature.features_tyre_temperature`), and each
  axle's from its own load and longitudinal friction power, averaged over the drive with that
  axle's friction power (longitudinal and lateral), as its wear is. A free-rolling rear axle
  carries less load and little longitudinal work: its tyres run cooler than the driven ones, and
  wear that depends on temperature (κ) must be taken at each axle's own.
* The car's rolling radius [mm], which turns the radius ratio into millimetres of tread.
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

import equinox as eqx
import numpy as np

from ..physics.vehicle import Vehicle
from .cornering_stiffness import TYPE_PRIOR_CORNERING, CorneringStiffness
from .features import StreamFeatures, compute_features
from .lateral_work import lateral_power
from .longitudinal_work import LongitudinalWork, longitudinal_work
from .order_stats import nanmedian
from .tyre_temperature import driven_tyre_temperature, features_tyre_temperature
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
    "tyre_temperature_front_c",
    "tyre_temperature_rear_c",
    "rolling_radius_mm",
)

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
    tyre_temperature_axle_c : ndarray, shape (2,)
        Each axle's tyre temperature, weighted by that axle's friction power [°C].
    rolling_radius_mm : float
        The car's nominal rolling radius [mm], the radius ratio's reference.

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
    tyre_temperature_axle_c: np.ndarray
    rolling_radius_mm: float

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
            "tyre_temperature_front_c": float(self.tyre_temperature_axle_c[0]),
            "tyre_temperature_rear_c": float(self.tyre_temperature_axle_c[1]),
            "rolling_radius_mm": float(self.rolling_radius_mm),
        }


def _extent(
    stream: ValidatedStream, feats: StreamFeatures, valid: np.ndarray, dt: float
) -> tuple[float, float, float]:
    """(duration [s], distance over the valid samples [km], odometer at the start [km]).

    The odometer is the first finite value of an optional ``odometer`` column [m]; NaN without.
    """
    data = stream.data
    vx = feats.vx_mps
    distance_km = float(np.sum(np.where(valid, vx, 0.0)) * dt / 1000.0)
    duration_s = float(feats.time_s[-1] - feats.time_s[0])
    odometer = data["odometer"].to_numpy(dtype=float) if "odometer" in data else np.array([np.nan])
    finite_odo = odometer[np.isfinite(odometer)]
    odometer_start_km = float(finite_odo[0] / 1000.0) if finite_odo.size else float("nan")
    return duration_s, distance_km, odometer_start_km


def _weighted_mean(temp: np.ndarray, weight: np.ndarray) -> float:
    """Mean of ``temp`` weighted by ``weight`` over finite samples of positive weight, plain where
    none has any."""
    ok = np.isfinite(temp) & (weight > 0)
    if ok.any():
        return float(np.sum(weight[ok] * temp[ok]) / np.sum(weight[ok]))
    return float(np.nanmean(temp))


def _temperatures(
    stream: ValidatedStream,
    feats: StreamFeatures,
    lon: LongitudinalWork,
    power_y_w: np.ndarray,
    driven_axle: str,
) -> tuple[float, float, np.ndarray]:
    """(median ambient [°C], NaN without a column; driven tyres' temperature [°C]; each axle's
    tyre temperature (2,) [°C]) (module docstring).

    The driven tyres' mean is weighted with the longitudinal friction kernel of both axles; each
    axle's with its own friction work, longitudinal (the kernel over Ĉ_x) plus lateral
    (``power_y_w``, (n, 2) [W]). A free axle's tyres are heated by their own load and linear-slip
    power (the kernel over Ĉ_x). Where Ĉ_x is unknown the longitudinal work is taken as none.
    """
    data = stream.data
    ambient = (
        data["ambient_temperature"].to_numpy(dtype=float)
        if "ambient_temperature" in data
        else np.array([np.nan])
    )
    ambient_c = nanmedian(ambient) if np.any(np.isfinite(ambient)) else float("nan")
    start_c = ambient_c if np.isfinite(ambient_c) else FALLBACK_AMBIENT_C
    driven = features_tyre_temperature(feats, ambient_c=start_c)
    kernel = np.where(lon.usable, np.maximum(lon.kernel_j, 0.0), 0.0)
    dt = 1.0 / feats.sample_rate_hz
    c_hat = lon.secant_stiffness if np.isfinite(lon.secant_stiffness) else np.inf
    work_x = kernel / c_hat  # [J] per sample
    power_x = work_x / dt  # [W]
    temps = []
    for axle, name in enumerate(("front", "rear")):
        if driven_axle in (name, "both"):
            temp = driven
        else:
            temp = driven_tyre_temperature(
                feats.time_s,
                feats.vx_mps,
                feats.fz_axle_n[:, axle] / 2.0,
                power_x[:, axle] / 2.0,
                ambient_c=start_c,
            )
        temps.append(_weighted_mean(temp, work_x[:, axle] + power_y_w[:, axle] * dt))
    return ambient_c, _weighted_mean(driven, lon.weight_j), np.asarray(temps)


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
    dt = 1.0 / feats.sample_rate_hz
    valid = feats.valid & np.isfinite(feats.vx_mps)
    duration_s, distance_km, odometer_start_km = _extent(stream, feats, valid, dt)
    lon = longitudinal_work(feats, vehicle, valid, dt)
    power_y = lateral_power(feats, vehicle, valid, cornering.per_axle)
    ambient_c, tyre_temp, axle_temp = _temperatures(
        stream, feats, lon, power_y, vehicle.driven_axle
    )
    return DriveWearEvidence(
        duration_s=duration_s,
        distance_km=distance_km,
        odometer_start_km=odometer_start_km,
        work_x_j=np.asarray(lon.work_x_j, dtype=float),
        work_x_sd_j=np.asarray(lon.work_x_sd_j, dtype=float),
        work_y_j=power_y.sum(axis=0) * dt,
        cornering=cornering,
        secant_stiffness=lon.secant_stiffness,
        radius_ratio_front_rear=lon.radius_ratio_front_rear,
        radius_ratio_front_rear_sd=lon.radius_ratio_front_rear_sd,
        free_rolling_s=float(feats.nuisances.radius_ratio_seconds),
        speed_scale=float(feats.nuisances.speed_scale),
        speed_scale_sd=float(feats.nuisances.speed_scale_sd),
        ambient_c=ambient_c,
        tyre_temperature_c=tyre_temp,
        tyre_temperature_axle_c=axle_temp,
        rolling_radius_mm=1000.0 * float(vehicle.wheel_radius_m),
    )
