"""The shipped database of longitudinal Magic Formula sets (``models/tyre_curves/``).

One row per distinct coefficient set found in public ``.tir`` tyre property files, each with its
source repository, path, commit and licence (``models/tyre_curves/README.md``). Read by the
per-tyre model's shape prior (:mod:`tyrebayes.inference.tyre.curve_prior`) and by the simulator,
which draws its tyres' curves from it (:func:`tyrebayes.simulate.tyre_spec.draw_database_curve`).
"""

from __future__ import annotations

import functools

import pandas as pd

from ._resources import models_dir

#: The classes of tyre that the package's cars run on.
PASSENGER_CLASSES = ("car", "suv")


@functools.cache
def _read() -> pd.DataFrame:
    return pd.read_csv(models_dir() / "tyre_curves" / "mf_longitudinal_sets.csv")


def load_tyre_curve_sets() -> pd.DataFrame:
    """All rows of the database (a copy: callers may modify it)."""
    return _read().copy()


def distinct_passenger_sets(table: pd.DataFrame | None = None) -> pd.DataFrame:
    """Car and SUV rows with distinct (C, E_traction), to two decimals.

    The same tyre recurs under several names (the TNO 205/60R15 set in many example files, with
    coefficients that differ in the fourth digit); each shape counts once.

    Examples
    --------
    >>> len(distinct_passenger_sets())
    9
    """
    table = load_tyre_curve_sets() if table is None else table
    cars = table[table["class"].isin(PASSENGER_CLASSES)]
    key = cars[["C", "E_traction"]].round(2)
    return cars.loc[~key.duplicated()].reset_index(drop=True)
