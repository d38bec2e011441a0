"""Tread-wear evidence of several stream files: one row per drive, in driving order.

:func:`with_cornering` puts a table's lateral work on another cornering stiffness without the
streams: the brush slip angle at a fixed μ is inversely proportional to c_y
(:func:`~tyrebayes.streams.lateral_work.brush_slip_angle`), so each drive's lateral work scales by
the c_y it was computed with over the new one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..physics.vehicle import Vehicle
from .cornering_stiffness import CorneringStiffness
from .wear_evidence import drive_wear_evidence


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


def with_cornering(
    table: pd.DataFrame, cornering: CorneringStiffness, rows: np.ndarray | None = None
) -> pd.DataFrame:
    """The evidence table with the lateral work of ``rows`` recomputed for ``cornering``.

    Parameters
    ----------
    table : pandas.DataFrame
        Wear evidence (:func:`wear_evidence_table`, or a fleet run's drive summaries), with the
        lateral work and the ``cornering_stiffness_*`` columns it was computed with.
    cornering : CorneringStiffness
        The axles' c_y to put the lateral work on; its log-sd and source replace the rows'.
    rows : ndarray of bool, optional
        The rows to change (default all).

    Returns
    -------
    pandas.DataFrame
        A copy; ``work_y_front_j`` and ``work_y_rear_j`` times (old c_y / new c_y) of their axle.

    Examples
    --------
    >>> table = pd.DataFrame({"work_y_front_j": [100.0], "work_y_rear_j": [50.0],
    ...     "cornering_stiffness_front_per_rad": [16.5], "cornering_stiffness_rear_per_rad": [16.5],
    ...     "cornering_stiffness_log_sd": [0.5], "cornering_stiffness_source": ["type_prior"]})
    >>> out = with_cornering(table, CorneringStiffness(33.0, 22.0, 0.1, "drive_lateral"))
    >>> out[["work_y_front_j", "work_y_rear_j", "cornering_stiffness_source"]].values.tolist()
    [[50.0, 37.5, 'drive_lateral']]
    """
    missing = [c for c in _CORNERING_COLUMNS if c not in table]
    if missing:
        raise ValueError(f"table: expected the lateral work's columns, missing {missing}")
    out = table.copy()
    rows = np.ones(len(out), dtype=bool) if rows is None else np.asarray(rows, dtype=bool)
    if "cornering_stiffness_source" not in out:  # a fleet run's summary: say what its rows had
        out["cornering_stiffness_source"] = np.where(type_prior_rows(out), "type_prior", "given")
    for axle, new in (("front", cornering.front_per_rad), ("rear", cornering.rear_per_rad)):
        old = out[f"cornering_stiffness_{axle}_per_rad"].to_numpy(dtype=float)
        work = out[f"work_y_{axle}_j"].to_numpy(dtype=float)
        out[f"work_y_{axle}_j"] = np.where(rows, work * old / float(new), work)
        out[f"cornering_stiffness_{axle}_per_rad"] = np.where(rows, float(new), old)
    log_sd = out["cornering_stiffness_log_sd"].to_numpy(dtype=float)
    out["cornering_stiffness_log_sd"] = np.where(rows, float(cornering.log_sd), log_sd)
    source = out["cornering_stiffness_source"].astype(str)
    out["cornering_stiffness_source"] = np.where(rows, cornering.source, source)
    return out


def type_prior_rows(table: pd.DataFrame) -> np.ndarray:
    """Per row, whether its ``cornering_stiffness_*`` columns hold the type prior's numbers (what
    a table without a ``cornering_stiffness_source`` column says of its rows)."""
    from .cornering_stiffness import TYPE_PRIOR_CORNERING as prior

    same = np.ones(len(table), dtype=bool)
    for column, value in (
        ("cornering_stiffness_front_per_rad", prior.front_per_rad),
        ("cornering_stiffness_rear_per_rad", prior.rear_per_rad),
        ("cornering_stiffness_log_sd", prior.log_sd),
    ):
        if column not in table:
            return np.zeros(len(table), dtype=bool)
        same &= np.isclose(table[column].to_numpy(dtype=float), value)
    return same


_CORNERING_COLUMNS = (
    "work_y_front_j",
    "work_y_rear_j",
    "cornering_stiffness_front_per_rad",
    "cornering_stiffness_rear_per_rad",
    "cornering_stiffness_log_sd",
)
