"""Channels sampled at their own instants, merged onto the union of those instants.

Shared by the MDF4 reader (:mod:`.io`) and the CAN conversion (:mod:`.can.convert`), which
sits above :mod:`.io` (``read_stream(profile=...)`` converts a CAN log): its own module, below
both, keeps the two from importing each other.
"""

from __future__ import annotations

import numpy as np
import pandas as pd


def merge_time_bases(columns: dict[str, tuple[np.ndarray, np.ndarray]]) -> pd.DataFrame:
    """Put channels sampled at their own instants into one table on the union of the instants.

    Examples
    --------
    >>> import numpy as np
    >>> merge_time_bases({"ax": (np.array([0.0, 0.2]), np.array([1.0, 2.0])),
    ...                   "ay": (np.array([0.1]), np.array([5.0]))})
       time   ax   ay
    0   0.0  1.0  NaN
    1   0.1  NaN  5.0
    2   0.2  2.0  NaN
    """
    union = np.unique(np.concatenate([t for t, _ in columns.values()]))
    data = {"time": union}
    for name, (t, x) in columns.items():
        col = np.full(union.shape, np.nan)
        # asammdf timestamps are sorted per channel; duplicates within a channel keep the last.
        col[np.searchsorted(union, t)] = x
        data[name] = col
    return pd.DataFrame(data)
