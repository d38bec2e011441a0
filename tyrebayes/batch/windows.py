"""The windows table: per-drive windowed observations in Parquet, what the tyre-set fit reads.

One row per window of one drive (:func:`tyrebayes.inference.observations_from_features`), with
the drive and tyre set it belongs to. It is a contract: a tyre set can be refitted from its
windows tables without reading its logs again (:func:`drives_from_windows` gives
:func:`tyrebayes.inference.stack_drives` its input).

Columns (SI, per window): ``drive_id``, ``tyre_set_id``, ``surface``, ``time_s`` [s, window
centre], ``slip``, ``slip_sd``, ``rho``, ``rho_sd`` [-], ``temperature_c`` [°C], ``load_change``
[-, the driven axle's ΔF_z/F_z,static], ``neighbour_slip`` [-], ``rho_score``,
``rho_score_slope`` (force-density score), ``at_limit`` (an ABS window: its ``rho`` observes
μ_max), ``imu_gain_log_sd`` [-].

Examples
--------
>>> import numpy as np
>>> from tyrebayes import WindowTable
>>> w = WindowTable.from_dict({k: np.zeros(3) for k in WINDOW_VALUES})
>>> table = windows_table(w, drive_id="d1", tyre_set_id="s1", surface="snow")
>>> drives, surfaces = drives_from_windows(table)
>>> surfaces, len(drives[0]), drives[0].at_limit.dtype
(['snow'], 3, dtype('bool'))
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .._errors import BadInputError
from ..inference.tyre.window_table import WindowTable

#: Per-window values of the table, as :func:`observations_from_features` names them.
WINDOW_VALUES = (
    "time_s",
    "slip",
    "slip_sd",
    "rho",
    "rho_sd",
    "temperature_c",
    "load_change",
    "neighbour_slip",
    "rho_score",
    "rho_score_slope",
    "at_limit",
    "imu_gain_log_sd",
)
KEY_COLUMNS = ("drive_id", "tyre_set_id", "surface")
WINDOW_COLUMNS = (*KEY_COLUMNS, *WINDOW_VALUES)


def windows_table(
    windows: WindowTable, *, drive_id: str, tyre_set_id: str, surface: str
) -> pd.DataFrame:
    """One drive's windows as rows of the windows table (columns :data:`WINDOW_COLUMNS`)."""
    columns = windows.to_dict()
    missing = [k for k in WINDOW_VALUES if k not in columns]
    if missing:
        raise ValueError(f"windows_table: expected windows with {missing}, got {sorted(columns)}")
    n = len(windows)
    table = pd.DataFrame(
        {
            "drive_id": pd.Series([drive_id] * n, dtype="string"),
            "tyre_set_id": pd.Series([tyre_set_id] * n, dtype="string"),
            "surface": pd.Series([surface] * n, dtype="string"),
        }
    )
    for k in WINDOW_VALUES:
        table[k] = np.asarray(columns[k], dtype=bool if k == "at_limit" else float)
    return table


def drives_from_windows(table: pd.DataFrame) -> tuple[list[WindowTable], list[str]]:
    """Split a windows table (one or many drives) into per-drive windows and surfaces.

    Drives come in order of first appearance, windows in table order (time order within a
    drive, which the slip-weight estimate needs).
    """
    missing = [c for c in WINDOW_COLUMNS if c not in table.columns]
    if missing:
        raise BadInputError(
            f"windows table: expected columns {list(WINDOW_COLUMNS)}, missing {missing}"
        )
    drives, surfaces = [], []
    for _, part in table.groupby("drive_id", sort=False):
        surface = part["surface"].unique()
        if len(surface) != 1:
            raise BadInputError(
                f"windows table: expected one surface per drive, got {sorted(map(str, surface))}"
            )
        drives.append(
            WindowTable.from_dict(
                {
                    k: part[k].to_numpy(dtype=bool if k == "at_limit" else float)
                    for k in WINDOW_VALUES
                }
            )
        )
        surfaces.append(str(surface[0]))
    return drives, surfaces
