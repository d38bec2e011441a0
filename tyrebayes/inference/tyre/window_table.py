"""One drive's windows as a typed table: one named, unit-carrying array per column.

What :func:`~.windows.windowed_observations`, :func:`~.windows.observations_from_features`
and :func:`tyrebayes.stream_windows` return, and what :func:`~.observations.stack_drives` and
:func:`tyrebayes.window_blocks` read. Re-exported by :mod:`tyrebayes.inference.tyre.data`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from jaxtyping import Bool, Float, Int

from ..._errors import BadInputError

#: Columns every table has: what the windowing of one drive always gives.
REQUIRED_COLUMNS = ("slip", "rho", "slip_sd", "rho_sd", "temperature_c", "time_s")
#: Columns a table may leave out (None): the stream pipeline gives them, hand-made windows and
#: :func:`~.windows.windowed_observations` may not.
OPTIONAL_COLUMNS = (
    "neighbour_slip",
    "load_change",
    "at_limit",
    "rho_score",
    "rho_score_slope",
    "imu_gain_log_sd",
    "drive",
)
_DTYPES = {"at_limit": bool, "drive": np.int64}


@dataclass(frozen=True, eq=False)
class WindowTable:
    """The short-window observations of one drive (or of drives joined end to end).

    One array per column, one entry per window, all of one length. Optional columns are None
    where not known; readers fill them as they document (:func:`tyrebayes.stack_drives`,
    :func:`tyrebayes.window_blocks`).

    Parameters
    ----------
    slip : Float[ndarray, "n"]
        Measured longitudinal slip σ_x of the driven axle [-] (window mean).
    rho : Float[ndarray, "n"]
        Measured normalised force ρ_x = F_x/F_z of the driven axle [-] (window mean; for an ABS
        window the total force ΣF_x/ΣF_z).
    slip_sd, rho_sd : Float[ndarray, "n"]
        Standard deviation of the noise of each window mean [-].
    temperature_c : Float[ndarray, "n"]
        Tyre temperature of the window [°C].
    time_s : Float[ndarray, "n"]
        Time of the window's centre [s] (drive time).
    neighbour_slip : Float[ndarray, "n"], optional
        Mean measured slip of the adjacent windows [-].
    load_change : Float[ndarray, "n"], optional
        The driven axle's ΔF_z/F_z,static [-] (window mean).
    at_limit : Bool[ndarray, "n"], optional
        ABS windows: their force observes μ_max, their slip is not used.
    rho_score, rho_score_slope : Float[ndarray, "n"], optional
        d/dρ log p(ρ_obs) and its derivative [1/-, 1/-²] at each window's force, p the density
        of the drive's measured forces (:func:`.force_density.force_density_score`; 0 for ABS
        windows).
    imu_gain_log_sd : Float[ndarray, "n"], optional
        Log-scale uncertainty of the IMU scale factor the drive's forces were divided by [-]
        (one value per drive, repeated over its windows).
    drive : Int[ndarray, "n"], optional
        A label per window that changes where a new drive begins (drives joined end to end);
        None: one drive.
    extra : mapping of str to Float[ndarray, "n"]
        Further per-window channels by name (the ``also`` channels of
        :func:`~.windows.windowed_observations`); empty by default.

    Raises
    ------
    BadInputError
        A column that is not one-dimensional, or not as long as ``slip``.

    Examples
    --------
    >>> t = 0.125 + 0.25 * np.arange(4)
    >>> table = WindowTable(
    ...     slip=np.full(4, 0.003), rho=np.full(4, 0.1), slip_sd=np.full(4, 2e-4),
    ...     rho_sd=np.full(4, 0.01), temperature_c=np.full(4, 20.0), time_s=t,
    ... )
    >>> len(table), table.select(table.time_s > 0.5).n_windows
    (4, 2)
    >>> sorted(table.to_dict())
    ['rho', 'rho_sd', 'slip', 'slip_sd', 'temperature_c', 'time_s']
    >>> WindowTable.from_dict({**table.to_dict(), "rho": np.zeros(3)})
    Traceback (most recent call last):
    ...
    tyrebayes._errors.BadInputError: window table: rho expected 4 windows, got 3
    """

    slip: Float[np.ndarray, "n"]
    rho: Float[np.ndarray, "n"]
    slip_sd: Float[np.ndarray, "n"]
    rho_sd: Float[np.ndarray, "n"]
    temperature_c: Float[np.ndarray, "n"]
    time_s: Float[np.ndarray, "n"]
    neighbour_slip: Float[np.ndarray, "n"] | None = None
    load_change: Float[np.ndarray, "n"] | None = None
    at_limit: Bool[np.ndarray, "n"] | None = None
    rho_score: Float[np.ndarray, "n"] | None = None
    rho_score_slope: Float[np.ndarray, "n"] | None = None
    imu_gain_log_sd: Float[np.ndarray, "n"] | None = None
    drive: Int[np.ndarray, "n"] | None = None
    extra: Mapping[str, Float[np.ndarray, "n"]] = field(default_factory=dict)

    def __post_init__(self):
        # Each column as an array of its dtype, checked for every way a table is made
        # (from_dict checks first: its callers get these one-line errors before a type
        # checker's on the annotations).
        columns = {
            name: getattr(self, name)
            for name in (*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS)
            if getattr(self, name) is not None
        }
        converted = _checked_columns({**columns, **self.extra})
        for name in columns:
            object.__setattr__(self, name, converted[name])
        object.__setattr__(self, "extra", {k: converted[k] for k in self.extra})

    @property
    def n_windows(self) -> int:
        """Number of windows."""
        return int(self.slip.shape[0])

    def __len__(self) -> int:
        return self.n_windows

    def __repr__(self) -> str:
        return f"WindowTable(n_windows={self.n_windows}, columns={list(self.to_dict())})"

    def to_dict(self) -> dict[str, np.ndarray]:
        """The columns by name (optional ones only where given, then the ``extra`` channels)."""
        names = (*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS)
        out = {name: getattr(self, name) for name in names if getattr(self, name) is not None}
        return {**out, **self.extra}

    @classmethod
    def from_dict(cls, columns: Mapping[str, np.ndarray]) -> WindowTable:
        """A table from columns by name (:meth:`to_dict`'s inverse); other names go to ``extra``.

        Raises :class:`~tyrebayes.BadInputError` naming any required column that is missing.
        """
        missing = [name for name in REQUIRED_COLUMNS if name not in columns]
        if missing:
            raise BadInputError(
                f"window table: expected columns {list(REQUIRED_COLUMNS)}, missing {missing}"
            )
        known = (*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS)
        checked = _checked_columns(dict(columns))
        return cls(
            **{name: checked[name] for name in known if name in checked},
            extra={name: values for name, values in checked.items() if name not in known},
        )

    def select(self, index) -> WindowTable:
        """The windows at ``index`` (a boolean mask, integer positions or a slice), every
        column."""
        if not isinstance(index, slice):
            index = np.asarray(index)
            if index.dtype == bool and index.shape != (self.n_windows,):
                raise BadInputError(
                    f"window table: mask expected shape ({self.n_windows},), got {index.shape}"
                )
        return WindowTable.from_dict({k: v[index] for k, v in self.to_dict().items()})

    def replace(self, **columns) -> WindowTable:
        """A copy with the given columns replaced (None drops an optional one; ``extra``
        replaces all the extra channels), checked as :meth:`from_dict` checks."""
        known = (*REQUIRED_COLUMNS, *OPTIONAL_COLUMNS)
        unknown = sorted(set(columns) - {*known, "extra"})
        if unknown:
            raise BadInputError(f"window table: expected columns of {list(known)}, got {unknown}")
        named = {name: columns.get(name, getattr(self, name)) for name in known}
        extra = columns.get("extra", self.extra)
        return WindowTable.from_dict({**{k: v for k, v in named.items() if v is not None}, **extra})

    @classmethod
    def concatenate(cls, tables: Sequence[WindowTable]) -> WindowTable:
        """The windows of ``tables`` one after another (each column present in all of them)."""
        if not tables:
            raise BadInputError("window table: expected at least one table, got none")
        names = list(tables[0].to_dict())
        for table in tables[1:]:
            if list(table.to_dict()) != names:
                raise BadInputError(
                    f"window table: expected columns {names}, got {list(table.to_dict())}"
                )
        return cls.from_dict(
            {name: np.concatenate([t.to_dict()[name] for t in tables]) for name in names}
        )


def _checked_columns(columns: dict[str, object]) -> dict[str, np.ndarray]:
    """Each column as a one-dimensional array of its dtype, all as long as ``slip``."""
    out = {
        name: np.asarray(values, dtype=_DTYPES.get(name, float)) for name, values in columns.items()
    }
    n = out["slip"].shape[0] if "slip" in out and out["slip"].ndim == 1 else None
    for name, values in out.items():
        if values.ndim != 1:
            raise BadInputError(
                f"window table: {name} expected one dimension, got shape {values.shape}"
            )
        if values.shape[0] != n:
            raise BadInputError(f"window table: {name} expected {n} windows, got {len(values)}")
    return out


__all__ = ["OPTIONAL_COLUMNS", "REQUIRED_COLUMNS", "WindowTable"]
