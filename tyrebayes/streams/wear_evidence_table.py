"""Tread-wear evidence of several stream files: one row per drive, in driving order."""

from __future__ import annotations

from pathlib import Path

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
