"""A fleet table (DESIGN.md contract) validated into index arrays."""

from __future__ import annotations

import equinox as eqx
import numpy as np
import pandas as pd

from ..._domain import C_XR_RANGE, MU_RANGE, SURFACES, TYRE_TYPES
from ..._errors import BadInputError
from .priors import load_tyre_type_priors

#: Plausible normalised cornering stiffness c_y [1/rad over the axle load]: car tyres 5-30.
C_Y_RANGE: tuple[float, float] = (1.0, 100.0)


class FleetData(eqx.Module):
    """A validated fleet table as index arrays (one latent stiffness per tyre set).

    ``tyre_type``, ``c_xr``, ``c_xr_sd``, ``c_y``, ``c_y_sd`` are per tyre set (``c_y`` and
    ``c_y_sd`` NaN for a set without a lateral estimate); ``row_tyre``, ``row_surface``, ``y``
    per row (one row per set and surface).
    """

    tyre_ids: tuple[str, ...]
    tyre_type: np.ndarray
    c_xr: np.ndarray
    c_xr_sd: np.ndarray
    c_y: np.ndarray
    c_y_sd: np.ndarray
    row_tyre: np.ndarray
    row_surface: np.ndarray
    y: np.ndarray
    outcome: str

    @property
    def n_tyres(self) -> int:
        return len(self.tyre_ids)

    @property
    def row_type(self) -> np.ndarray:
        return self.tyre_type[self.row_tyre]

    @property
    def lateral_tyres(self) -> np.ndarray:
        """Indices of the sets with a lateral estimate (finite ``c_y``)."""
        return np.flatnonzero(np.isfinite(self.c_y))


def fleet_data_from_table(
    table: pd.DataFrame,
    outcome: str = "mu",
    *,
    default_c_xr_sd: float | None = None,
    require_outcome: bool = True,
    lateral_only_rows: bool = False,
) -> FleetData:
    """Validate a fleet table (DESIGN.md contract) and turn it into :class:`FleetData`.

    Raises :class:`tyrebayes.BadInputError` (one line, expected vs got) for a missing column, an
    unknown tyre type or surface, a non-positive or missing stiffness, a non-finite outcome, a
    tyre set whose rows disagree on its stiffness, or fewer than two rows of a type on a surface.
    Values no tyre can have fail here too, before a fit fails on them: ``c_xr`` outside
    :data:`~tyrebayes._domain.C_XR_RANGE`, an outcome named ``mu...`` outside
    :data:`~tyrebayes._domain.MU_RANGE` (with a hint when it looks like percent). Without a
    ``surface`` column every row is on snow (the thesis' setting).

    Optional lateral columns: ``c_y`` (the set's normalised cornering stiffness [1/rad over the
    static axle load], empty where the set has no lateral estimate) with ``c_y_sd`` (its standard
    error, required beside ``c_y``); a ``c_y`` outside :data:`C_Y_RANGE`, a missing or
    non-positive ``c_y_sd`` where ``c_y`` is given, or a set whose rows disagree on them fail.
    With ``lateral_only_rows`` (what :func:`~tyrebayes.inference.fleet.fit.fit_fleet` passes) a
    row with a ``c_y`` and an empty outcome is a set that cornered but never observed the
    outcome: the set keeps its stiffness and c_y, the row leaves the outcome's rows (at least
    one row must have an outcome).
    """
    _check_columns(table, outcome, require_outcome)
    _check_plausible(table, outcome if require_outcome else None)
    types, surface = _types_and_surfaces(table)
    c_xr, c_sd = _stiffness_columns(table, default_c_xr_sd)
    c_y, cy_sd = _lateral_columns(table)
    if require_outcome:
        y = _outcome_column(table, outcome, np.isfinite(c_y) & lateral_only_rows)
    else:
        y = np.full(len(table), np.nan)
    ids = table["tyre_id"].astype(str).to_numpy()
    uniq, row_tyre = _tyre_index(ids, surface)
    type_idx = types.map({t: i for i, t in enumerate(TYRE_TYPES)}).to_numpy(int)
    tyre_type = np.zeros(len(uniq), int)
    tyre_c, tyre_sd = np.zeros(len(uniq)), np.zeros(len(uniq))
    tyre_cy, tyre_cy_sd = np.full(len(uniq), np.nan), np.full(len(uniq), np.nan)
    for k in range(len(uniq)):
        rows = row_tyre == k
        tyre_type[k], tyre_c[k], tyre_sd[k] = _set_stiffness(
            uniq[k], type_idx[rows], c_xr[rows], c_sd[rows]
        )
        tyre_cy[k], tyre_cy_sd[k] = _set_lateral(uniq[k], c_y[rows], cy_sd[rows])
    row_surface = surface.map({s: i for i, s in enumerate(SURFACES)}).to_numpy(int)
    row_tyre = np.asarray(row_tyre, int)
    if require_outcome:
        # Lateral-only rows leave the outcome's rows; their sets stay (stiffness and c_y).
        has_y = np.isfinite(y)
        _check_rows_per_type(surface.to_numpy()[has_y], types.to_numpy()[has_y])
        row_tyre, row_surface, y = row_tyre[has_y], row_surface[has_y], y[has_y]
    return FleetData(
        tyre_ids=tuple(uniq.tolist()),
        tyre_type=tyre_type,
        c_xr=tyre_c,
        c_xr_sd=tyre_sd,
        c_y=tyre_cy,
        c_y_sd=tyre_cy_sd,
        row_tyre=row_tyre,
        row_surface=row_surface,
        y=y,
        outcome=outcome,
    )


def _check_columns(table: pd.DataFrame, outcome: str, require_outcome: bool) -> None:
    """The contract's columns are there (the outcome's when it is required), and a row."""
    needed = ["tyre_id", "tyre_type", "c_xr"] + ([outcome] if require_outcome else [])
    missing = [c for c in needed if c not in table.columns]
    if missing:
        raise BadInputError(
            f"fleet table: expected columns {needed}, missing {missing} (got {list(table.columns)})"
        )
    if len(table) == 0:
        raise BadInputError("fleet table: expected at least one row, got none")


def _types_and_surfaces(table: pd.DataFrame) -> tuple[pd.Series, pd.Series]:
    """Per row the tyre type and the surface (snow without a ``surface`` column), checked
    against the known ones."""
    types = table["tyre_type"].astype(str).str.strip()
    unknown = sorted(set(types) - set(TYRE_TYPES))
    if unknown:
        raise BadInputError(f"tyre_type: expected one of {list(TYRE_TYPES)}, got {unknown}")
    if "surface" not in table.columns:
        return types, pd.Series("snow", index=table.index)
    surface = table["surface"].astype(str).str.strip()
    bad = sorted(set(surface) - set(SURFACES))
    if bad:
        raise BadInputError(f"surface: expected one of {list(SURFACES)}, got {bad}")
    return types, surface


def _stiffness_columns(
    table: pd.DataFrame, default_c_xr_sd: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """Per row ``c_xr`` and its sd (the type priors' default sd without a ``c_xr_sd`` column),
    checked: finite and positive."""
    c_xr = pd.to_numeric(table["c_xr"], errors="coerce").to_numpy(float)
    if not np.all(np.isfinite(c_xr)):
        raise BadInputError(
            "c_xr: expected a finite stiffness in every row, got "
            f"{int((~np.isfinite(c_xr)).sum())} missing or non-numeric"
        )
    if np.any(c_xr <= 0):
        raise BadInputError(f"c_xr: expected positive stiffness, got minimum {c_xr.min():g}")
    if "c_xr_sd" in table.columns:
        c_sd = pd.to_numeric(table["c_xr_sd"], errors="coerce").to_numpy(float)
        if not np.all(np.isfinite(c_sd) & (c_sd > 0)):
            raise BadInputError("c_xr_sd: expected positive finite values, got missing or <= 0")
        return c_xr, c_sd
    if default_c_xr_sd is None:
        default_c_xr_sd = load_tyre_type_priors().default_c_xr_sd
    return c_xr, np.full(len(table), float(default_c_xr_sd))


def _outcome_column(table: pd.DataFrame, outcome: str, may_be_empty: np.ndarray) -> np.ndarray:
    """Per row the outcome: finite except in the rows that ``may_be_empty`` (lateral-only
    rows), and given in one row at least."""
    y = pd.to_numeric(table[outcome], errors="coerce").to_numpy(float)
    if not np.all(np.isfinite(y) | may_be_empty):
        raise BadInputError(f"{outcome}: expected finite numbers, got missing or non-numeric")
    if not np.isfinite(y).any():
        raise BadInputError(f"{outcome}: expected at least one row with a value, got none")
    return y


def _tyre_index(ids: np.ndarray, surface: pd.Series) -> tuple[np.ndarray, np.ndarray]:
    """The tyre sets (sorted ids) and each row's set; one row per set and surface."""
    uniq, row_tyre = np.unique(ids, return_inverse=True)
    key = pd.Series(list(zip(ids, surface, strict=True)))
    if key.duplicated().any():
        raise BadInputError(
            f"fleet table: expected one row per tyre_id and surface, got duplicates "
            f"{key[key.duplicated()].iloc[0]}"
        )
    return uniq, row_tyre


def _set_stiffness(
    tyre_id: str, type_idx: np.ndarray, c_xr: np.ndarray, c_sd: np.ndarray
) -> tuple[int, float, float]:
    """A set's type index, ``c_xr`` and sd from its rows, which must agree on them."""
    if len(set(type_idx)) > 1 or np.ptp(c_xr) > 1e-9:
        raise BadInputError(
            f"tyre_id {tyre_id}: expected one tyre_type and c_xr for all its rows, got several"
        )
    return int(type_idx[0]), float(c_xr[0]), float(c_sd[0])


def _set_lateral(tyre_id: str, c_y: np.ndarray, cy_sd: np.ndarray) -> tuple[float, float]:
    """A set's ``c_y`` and sd from its rows (NaN without one), which must agree on them."""
    lateral = np.isfinite(c_y)
    if not lateral.any():
        return np.nan, np.nan
    values = c_y[lateral]
    if not lateral.all() or np.ptp(values) > 1e-9 * values[0]:
        raise BadInputError(
            f"tyre_id {tyre_id}: expected one c_y for all its rows (or none), got {c_y.tolist()}"
        )
    return float(values[0]), float(cy_sd[lateral][0])


def _check_rows_per_type(surface: np.ndarray, types: np.ndarray) -> None:
    """At least two outcome rows of each tyre type on each surface it is on (its scatter)."""
    counts = pd.crosstab(surface, types)
    thin = [
        (s, t, int(counts.loc[s, t]))
        for s in counts.index
        for t in counts.columns
        if 0 < counts.loc[s, t] < 2
    ]
    if thin:
        s, t, n = thin[0]
        raise BadInputError(
            f"fleet table: expected at least 2 rows per tyre type on a surface to estimate its "
            f"scatter, got {n} for {t} on {s}"
        )


def _lateral_columns(table: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Per row ``c_y`` and ``c_y_sd`` (NaN where the set has no lateral estimate), checked."""
    if "c_y" not in table.columns:
        nan = np.full(len(table), np.nan)
        return nan, nan.copy()
    if "c_y_sd" not in table.columns:
        raise BadInputError("fleet table: expected a c_y_sd column beside c_y, got none")
    c_y = pd.to_numeric(table["c_y"], errors="coerce").to_numpy(float)
    sd = pd.to_numeric(table["c_y_sd"], errors="coerce").to_numpy(float)
    given = np.isfinite(c_y)
    lo, hi = C_Y_RANGE
    bad = np.flatnonzero(given & ((c_y < lo) | (c_y > hi)))
    if bad.size:
        raise BadInputError(
            f"c_y: expected a normalised cornering stiffness in [{lo:g}, {hi:g}] 1/rad (car "
            f"tyres 5-30), got {c_y[bad[0]]:g} in row {int(bad[0])}"
        )
    bad = np.flatnonzero(given & ~(np.isfinite(sd) & (sd > 0)))
    if bad.size:
        raise BadInputError(
            f"c_y_sd: expected a positive finite value where c_y is given, got {sd[bad[0]]} "
            f"in row {int(bad[0])}"
        )
    return c_y, np.where(given, sd, np.nan)


def _first_outside(table: pd.DataFrame, column: str, inside) -> tuple[int, float] | None:
    """(row, value) of the first finite value of ``column`` that is not ``inside``, or None."""
    x = pd.to_numeric(table[column], errors="coerce").to_numpy(float)
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(np.isfinite(x) & ~inside(x))
    return None if bad.size == 0 else (int(bad[0]), float(x[bad[0]]))


def _check_plausible(table: pd.DataFrame, outcome: str | None) -> None:
    """One-line errors for stiffness or friction values no tyre can have (a unit mistake).

    Missing, non-numeric, zero and negative values keep the table checks' own messages.
    """
    lo, hi = C_XR_RANGE
    found = _first_outside(table, "c_xr", lambda x: (x <= 0) | ((lo <= x) & (x <= hi)))
    if found is not None:
        raise BadInputError(
            f"c_xr: expected a stiffness in [{lo:g}, {hi:g}] (car tyres 20-60), got "
            f"{found[1]:g} in row {found[0]}"
        )
    if outcome is not None and outcome.lower().startswith("mu"):
        mu_lo, mu_hi = MU_RANGE
        found = _first_outside(table, outcome, lambda x: (mu_lo < x) & (x < mu_hi))
        if found is not None:
            row, value = found
            hint = " (percent? divide by 100)" if mu_hi <= value <= 100 * mu_hi else ""
            raise BadInputError(
                f"{outcome}: expected a friction coefficient in ({mu_lo:g}, {mu_hi:g}), got "
                f"{value:g} in row {row}{hint}"
            )
