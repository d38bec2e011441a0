"""A car's drive history as wear-model input: per-drive evidence, tyre sets, tread readings.

:func:`drive_history` reads the per-drive evidence table (the columns of
:data:`tyrebayes.streams.wear_evidence.WEAR_EVIDENCE_COLUMNS`, one row per drive in drive order),
finds the tyre changes (:func:`~tyrebayes.inference.wear.changepoint.detect_tyre_changes`) and
lays out which tyre pair was on which axle in every interval. Each drive stands for the distance
to the next drive's odometer reading (its own distance where there is no odometer; the last
drive's, to a later tread reading's odometer: :meth:`DriveHistory.through`): its friction
work is scaled by that distance over its own. The lateral work (``work_y_front_j``,
``work_y_rear_j``) and the log-sd of the cornering stiffness behind it are optional columns: a
table without them (or with them empty) has no lateral work (``lateral_source`` ``"none"``).
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import numpy as np
import pandas as pd

from ..._errors import BadInputError
from ...physics.wear import TreadGeometry
from ...streams.wear_evidence_table import type_prior_rows
from .changepoint import FALSE_ALARM_RATE, TyreChanges, detect_tyre_changes

#: Evidence columns the history needs (a subset of WEAR_EVIDENCE_COLUMNS; ``speed_scale`` is
#: optional).
HISTORY_COLUMNS: tuple[str, ...] = (
    "distance_km",
    "odometer_start_km",
    "work_x_front_j",
    "work_x_front_sd_j",
    "work_x_rear_j",
    "work_x_rear_sd_j",
    "radius_ratio_front_rear",
    "radius_ratio_front_rear_sd",
    "tyre_temperature_c",
)
#: Optional evidence columns: the lateral work, the c_y behind it and where that came from.
LATERAL_COLUMNS: tuple[str, ...] = (
    "work_y_front_j",
    "work_y_rear_j",
    "cornering_stiffness_log_sd",
)
#: Axle names of tread-depth readings, in axle order.
AXLES = ("front", "rear")
#: A reading may exceed an earlier one of the same axle and tyre set by this much (gauge
#: resolution and reading noise) before the readings count as increasing [mm].
READING_TOLERANCE_MM = 0.5


class TreadReadings(eqx.Module):
    """Tread-depth readings: ``odometer_km`` [km], ``axle`` (0 front, 1 rear), ``depth_mm``."""

    odometer_km: np.ndarray
    axle: np.ndarray
    depth_mm: np.ndarray


class DriveHistory(eqx.Module):
    """One car's drives, in order, with its tyre sets (arrays of length n drives).

    Attributes
    ----------
    odometer_km : start of each drive's interval [km]
    interval_km : distance each drive stands for [km]
    scale : interval_km / the drive's own distance [-]
    work_j, work_sd_j : (n, 2) longitudinal friction work per axle over the interval [J], its sd
    work_y_j : (n, 2) lateral friction work per axle over the interval [J] (eq. 4.19b)
    lateral_log_sd : log-sd of the lateral work's scale (the cornering stiffness', W_y ∝ 1/c_y)
    lateral_source : where c_y came from (``lateral_fit``, ``type_prior``, ``given``, ``none``)
    ratio_mm, ratio_sd_mm : (n,) front/rear radius ratio as (ratio − 1) R_0 [mm] and its sd
    speed_scale_mm : (n,) free-rolling axle's radius change against GNSS [mm] (NaN: none)
    tyre_temperature_c : (n, 2) each axle's friction-power weighted tyre temperature [°C] (the
        driven tyres' for both axles where the evidence has no per-axle columns)
    segment : (n,) tyre-set segment of each drive
    pair : (n, 2) tyre pair on the (front, rear) axle in each drive's interval
    n_pairs : number of tyre pairs in the history
    changes : TyreChanges
    radius_mm : R_0 used for the mm scale: the car's rolling radius where the evidence gives it
        (``rolling_radius_mm``, the radius the wheel speeds were read with), else the tread
        geometry's outer radius
    """

    odometer_km: np.ndarray
    interval_km: np.ndarray
    scale: np.ndarray
    work_j: np.ndarray
    work_sd_j: np.ndarray
    work_y_j: np.ndarray
    lateral_log_sd: float
    ratio_mm: np.ndarray
    ratio_sd_mm: np.ndarray
    speed_scale_mm: np.ndarray
    tyre_temperature_c: np.ndarray
    segment: np.ndarray
    pair: np.ndarray
    n_pairs: int = eqx.field(static=True)
    changes: TyreChanges
    radius_mm: float = eqx.field(static=True)
    lateral_source: str = eqx.field(static=True, default="none")

    @property
    def n_drives(self) -> int:
        return int(self.ratio_mm.size)

    @property
    def total_km(self) -> float:
        return float(self.interval_km.sum())

    @property
    def end_km(self) -> float:
        """Odometer at the end of the last drive's interval [km]."""
        return float(self.odometer_km[-1] + self.interval_km[-1])

    def through(self, odometer_km: float) -> DriveHistory:
        """The history with its last drive standing for the distance to ``odometer_km``.

        Every other drive stands for the distance to the next one's odometer; the last one has
        no next drive and stands for its own distance. A later odometer reading (a tread
        reading's, at the service after the last logged drive) closes its interval as a next
        drive would: the car drove on between them, and the tread the reading measured wore
        over that distance too. Its works grow with its interval; an odometer at or before the
        history's end changes nothing.
        """
        grow = (float(odometer_km) - float(self.odometer_km[-1])) / float(self.interval_km[-1])
        if not np.isfinite(grow) or grow <= 1.0:
            return self
        factor = np.ones(self.n_drives)
        factor[-1] = grow
        return dataclasses.replace(
            self,
            interval_km=self.interval_km * factor,
            scale=self.scale * factor,
            work_j=self.work_j * factor[:, None],
            work_sd_j=self.work_sd_j * factor[:, None],
            work_y_j=self.work_y_j * factor[:, None],
        )

    def with_change_types(self, change_type: tuple[str, ...], probability) -> DriveHistory:
        """The history with its changes' types (and their probabilities) replaced, and the tyre
        pairs laid out again for them."""
        changes = dataclasses.replace(
            self.changes,
            change_type=tuple(change_type),
            probability=np.asarray(probability, dtype=float),
        )
        pair, n_pairs = _pairs(changes, self.n_drives)
        return dataclasses.replace(self, changes=changes, pair=pair, n_pairs=n_pairs)


def _column(table: pd.DataFrame, name: str) -> np.ndarray:
    if name not in table:
        raise BadInputError(f"drive history: expected column {name!r}, got {list(table.columns)}")
    return pd.to_numeric(table[name], errors="coerce").to_numpy(dtype=float)


def drive_history(
    table: pd.DataFrame,
    geom: TreadGeometry | None = None,
    *,
    false_alarm: float = FALSE_ALARM_RATE,
) -> DriveHistory:
    """Build a :class:`DriveHistory` from per-drive evidence rows (already in drive order).

    Raises :class:`~tyrebayes.BadInputError` for fewer than two drives, missing columns, drives
    without a radius ratio or friction work, or an odometer that runs backwards.

    Examples
    --------
    Two drives of the shipped segment (:func:`tyrebayes.wear_evidence_table`):

    >>> from tyrebayes import load_vehicle, wear_evidence_table
    >>> from tyrebayes._resources import data_dir
    >>> path = data_dir() / "comma2k19_rav4_segment.csv"
    >>> table = wear_evidence_table([path, path], load_vehicle("suv_rav4"))
    >>> history = drive_history(table)
    >>> history.work_j.shape, history.lateral_source, history.changes.index.size
    ((2, 2), 'type_prior', 0)
    >>> drive_history(table.iloc[:1])
    Traceback (most recent call last):
    ...
    tyrebayes._errors.BadInputError: drive history: expected at least 2 drives, got 1
    """
    geom = TreadGeometry() if geom is None else geom
    n = len(table)
    if n < 2:
        raise BadInputError(f"drive history: expected at least 2 drives, got {n}")
    missing = [c for c in HISTORY_COLUMNS if c not in table]
    if missing:
        raise BadInputError(f"drive history: expected columns {missing}, not found")
    work_y, lateral_log_sd, lateral_source = _lateral(table, n)
    distance, work, work_sd, ratio, ratio_sd = _evidence(table)
    odometer, interval = _intervals(_column(table, "odometer_start_km"), distance)
    scale = interval / distance
    radius_mm = _radius_mm(table, geom)
    ratio_mm = (ratio - 1.0) * radius_mm
    ratio_sd_mm = ratio_sd * radius_mm
    ss = _column(table, "speed_scale") if "speed_scale" in table else np.full(n, np.nan)
    ss_mm = -(ss - 1.0) * radius_mm
    work_iv = (work + work_y) * scale[:, None]  # both components wear the tread
    changes = detect_tyre_changes(
        ratio_mm, work_iv[:, 0] - work_iv[:, 1], ss_mm, false_alarm=false_alarm
    )
    pair, n_pairs = _pairs(changes, n)
    return DriveHistory(
        odometer_km=odometer,
        interval_km=interval,
        scale=scale,
        work_j=work * scale[:, None],
        work_sd_j=work_sd * scale[:, None],
        work_y_j=work_y * scale[:, None],
        lateral_log_sd=lateral_log_sd,
        ratio_mm=ratio_mm,
        ratio_sd_mm=ratio_sd_mm,
        speed_scale_mm=ss_mm,
        tyre_temperature_c=_tyre_temperatures(table),
        segment=changes.segments(n),
        pair=pair,
        n_pairs=n_pairs,
        changes=changes,
        radius_mm=radius_mm,
        lateral_source=lateral_source,
    )


def _evidence(table: pd.DataFrame) -> tuple[np.ndarray, ...]:
    """(distance [km], work (n, 2) [J], its sd, radius ratio, its sd) of the rows, checked.

    Every drive needs a distance > 0, finite friction work and a radius ratio with its sd.
    """
    n = len(table)
    distance = _column(table, "distance_km")
    work = np.column_stack([_column(table, "work_x_front_j"), _column(table, "work_x_rear_j")])
    work_sd = np.column_stack(
        [_column(table, "work_x_front_sd_j"), _column(table, "work_x_rear_sd_j")]
    )
    ratio = _column(table, "radius_ratio_front_rear")
    ratio_sd = _column(table, "radius_ratio_front_rear_sd")
    if not np.all(np.isfinite(distance) & (distance > 0)):
        raise BadInputError("drive history: expected every drive to have distance_km > 0")
    if not np.all(np.isfinite(work)):
        raise BadInputError("drive history: expected finite friction work for every drive")
    bad = ~(np.isfinite(ratio) & np.isfinite(ratio_sd))
    if bad.any():
        raise BadInputError(
            f"drive history: expected a radius ratio for every drive (too little straight free "
            f"rolling), got none for {int(bad.sum())} of {n}"
        )
    return distance, work, work_sd, ratio, ratio_sd


def _intervals(odometer: np.ndarray, distance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(start of each drive's interval [km], distance it stands for [km]).

    With an odometer on every drive each stands for the distance to the next one's start (the
    last for its own); without, each for its own distance, the starts their running sum.
    """
    if np.all(np.isfinite(odometer)):
        interval = np.diff(odometer)
        if np.any(interval < distance[:-1] * 0.99):
            raise BadInputError(
                "drive history: expected odometer readings that grow by at least each drive's "
                "distance, got one that does not (drives out of order or of another car?)"
            )
        interval = np.append(interval, distance[-1])
    else:
        interval = distance.copy()
        odometer = np.concatenate([[0.0], np.cumsum(distance[:-1])])
    return odometer, interval


def _tyre_temperatures(table: pd.DataFrame) -> np.ndarray:
    """Each drive's tyre temperature per axle, (n, 2) [°C]: the per-axle columns where the
    evidence has them, else the driven tyres' for both; a missing one the drives' mean of its
    axle (20 °C: none at all)."""
    names = ("tyre_temperature_front_c", "tyre_temperature_rear_c")
    if all(name in table for name in names):
        temp = np.column_stack([_column(table, name) for name in names])
    else:
        temp = np.repeat(_column(table, "tyre_temperature_c")[:, None], 2, axis=1)
    out = np.empty_like(temp)
    for axle in range(2):
        t = temp[:, axle]
        out[:, axle] = np.where(np.isfinite(t), t, np.nanmean(t) if np.isfinite(t).any() else 20.0)
    return out


def _radius_mm(table: pd.DataFrame, geom: TreadGeometry) -> float:
    """R_0 of the radius ratio's mm scale: a tread loss Δ moves the rolling radius the wheel
    speeds are read with by Δ, so the ratio moves by Δ / R_roll. The evidence's
    ``rolling_radius_mm`` (one car: its median), else the geometry's outer radius."""
    if "rolling_radius_mm" in table:
        radius = _column(table, "rolling_radius_mm")
        if np.isfinite(radius).any():
            return float(np.nanmedian(radius))
    return float(geom.outer_radius_mm)


def _pairs(changes: TyreChanges, n: int) -> tuple[np.ndarray, int]:
    """The tyre pair on the (front, rear) axle in each of ``n`` drives, and the number of pairs.

    A rotation swaps the current pairs; a replacement mounts two new ones.
    """
    pair = np.zeros((n, 2), dtype=int)
    current, next_pair = np.array([0, 1]), 2
    change_at = dict(zip(changes.index.tolist(), changes.change_type, strict=True))
    for k in range(n):
        if k in change_at:
            if change_at[k] == "rotation":
                current = current[::-1].copy()
            else:
                current = np.array([next_pair, next_pair + 1])
                next_pair += 2
        pair[k] = current
    return pair, int(next_pair)


def _lateral(table: pd.DataFrame, n: int) -> tuple[np.ndarray, float, str]:
    """The lateral work (n, 2) [J], its scale's log-sd and the stiffness source of a table."""
    if not all(c in table for c in LATERAL_COLUMNS):
        return np.zeros((n, 2)), 0.0, "none"
    work_y = np.column_stack([_column(table, "work_y_front_j"), _column(table, "work_y_rear_j")])
    if np.all(np.isnan(work_y)):  # empty columns: a table made without the lateral work
        return np.zeros((n, 2)), 0.0, "none"
    if not np.all(np.isfinite(work_y) & (work_y >= 0)):
        raise BadInputError("drive history: expected finite lateral work >= 0 for every drive")
    log_sd = _column(table, "cornering_stiffness_log_sd")
    if not np.all(np.isfinite(log_sd) & (log_sd >= 0)):
        raise BadInputError("drive history: expected cornering_stiffness_log_sd >= 0 per drive")
    if "cornering_stiffness_source" in table:
        sources = sorted({str(v) for v in table["cornering_stiffness_source"]})
    else:  # a fleet run's summary: the type prior's numbers say the type prior
        sources = ["type_prior" if type_prior_rows(table).all() else "given"]
    # one tyre stiffness for the history: the widest stated uncertainty of its drives
    return work_y, float(log_sd.max()), "+".join(sources)


def tread_readings(table: pd.DataFrame) -> TreadReadings:
    """Readings from a table with ``odometer_km``, ``axle`` (front/rear) and ``depth_mm``.

    Rows are sorted by odometer; an axle other than front/rear, a non-number or a depth outside
    (0, 15] mm is a :class:`~tyrebayes.BadInputError`.

    Examples
    --------
    >>> table = pd.DataFrame({"odometer_km": [12000.0, 0.0], "axle": ["Rear", "front"],
    ...                       "depth_mm": [6.5, 8.0]})
    >>> readings = tread_readings(table)
    >>> readings.odometer_km.tolist(), readings.axle.tolist(), readings.depth_mm.tolist()
    ([0.0, 12000.0], [0, 1], [8.0, 6.5])
    """
    for name in ("odometer_km", "axle", "depth_mm"):
        if name not in table:
            raise BadInputError(
                f"tread readings: expected columns odometer_km, axle, depth_mm, got "
                f"{list(table.columns)}"
            )
    axle_names = table["axle"].astype(str).str.strip().str.lower()
    unknown = sorted(set(axle_names) - set(AXLES))
    if unknown:
        raise BadInputError(f"tread readings: expected axle front or rear, got {unknown}")
    odo = pd.to_numeric(table["odometer_km"], errors="coerce").to_numpy(dtype=float)
    depth = pd.to_numeric(table["depth_mm"], errors="coerce").to_numpy(dtype=float)
    if not (np.all(np.isfinite(odo)) and np.all(np.isfinite(depth))):
        raise BadInputError("tread readings: expected numbers in odometer_km and depth_mm")
    if np.any((depth <= 0) | (depth > 15)):
        raise BadInputError(f"tread readings: expected depths in (0, 15] mm, got {depth.min():g}")
    axle = np.array([AXLES.index(a) for a in axle_names], dtype=int)
    order = np.argsort(odo, kind="stable")
    return TreadReadings(odo[order], axle[order], depth[order])


def reading_exposure(
    history: DriveHistory, readings: TreadReadings
) -> tuple[np.ndarray, np.ndarray]:
    """How much of each interval's wear of each axle position a reading has seen.

    Returns ``(A, pair)``: ``A[i, j, a]`` in [0, 1] is the fraction of interval j completed by
    reading i's odometer, where interval j's axle a carried the pair that reading i measured
    (the pair on the read axle at the reading); ``pair[i]`` is that pair. Raises
    :class:`~tyrebayes.BadInputError` when a reading exceeds an earlier one of the same pair by
    more than :data:`READING_TOLERANCE_MM`.
    """
    start = history.odometer_km
    frac = np.clip((readings.odometer_km[:, None] - start[None, :]) / history.interval_km, 0, 1)
    # the drive whose interval holds the reading decides which pair was on the axle
    # a reading at the start of a drive closes the interval before it (the service came first)
    at = np.clip(np.searchsorted(start, readings.odometer_km, side="left") - 1, 0, None)
    read_pair = history.pair[at, readings.axle]
    on = history.pair[None, :, :] == read_pair[:, None, None]  # (m, n, 2)
    last: dict[int, float] = {}
    for i, p in enumerate(read_pair.tolist()):
        if p in last and readings.depth_mm[i] > last[p] + READING_TOLERANCE_MM:
            raise BadInputError(
                f"tread readings: expected depths that do not increase on one tyre set, got "
                f"{readings.depth_mm[i]:g} mm after {last[p]:g} mm "
                f"({AXLES[readings.axle[i]]} axle, {readings.odometer_km[i]:g} km)"
            )
        last[p] = float(readings.depth_mm[i])
    return frac[:, :, None] * on, read_pair
