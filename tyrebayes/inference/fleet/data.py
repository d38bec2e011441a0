"""A fleet table (DESIGN.md contract) validated into index arrays."""

from __future__ import annotations

import equinox as eqx
import numpy as np
import pandas as pd

from ..._domain import SURFACES, TYRE_TYPES
from ..._errors import BadInputError
from .priors import load_tyre_type_priors


class FleetData(eqx.Module):
    """A validated fleet table as index arrays (one latent stiffness per tyre set).

    ``tyre_type``, ``c_xr``, ``c_xr_sd`` are per tyre set; ``row_tyre``, ``row_surface``, ``y``
    per row (one row per set and surface).
    """

    tyre_ids: tuple[str, ...]
    tyre_type: np.ndarray
    c_xr: np.ndarray
    c_xr_sd: np.ndarray
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


def fleet_data_from_table(
    table: pd.DataFrame,
    outcome: str = "mu",
    *,
    default_c_xr_sd: float | None = None,
    require_outcome: bool = True,
) -> FleetData:
    """Validate a fleet table (DESIGN.md contract) and turn it into :class:`FleetData`.

    Raises :class:`tyrebayes.BadInputError` (one line, expected vs got) for a missing column, an
    unknown tyre type or surface, a non-positive or missing stiffness, a non-finite outcome, a
    tyre set whose rows disagree on its stiffness, or fewer than two rows of a type on a surface.
    Without a ``surface`` column every row is on snow (the thesis' setting).
    """
    if default_c_xr_sd is None:
        default_c_xr_sd = load_tyre_type_priors().default_c_xr_sd
    needed = ["tyre_id", "tyre_type", "c_xr"] + ([outcome] if require_outcome else [])
    missing = [c for c in needed if c not in table.columns]
    if missing:
        raise BadInputError(
            f"fleet table: expected columns {needed}, missing {missing} (got {list(table.columns)})"
        )
    if len(table) == 0:
        raise BadInputError("fleet table: expected at least one row, got none")
    types = table["tyre_type"].astype(str).str.strip()
    unknown = sorted(set(types) - set(TYRE_TYPES))
    if unknown:
        raise BadInputError(f"tyre_type: expected one of {list(TYRE_TYPES)}, got {unknown}")
    if "surface" in table.columns:
        surface = table["surface"].astype(str).str.strip()
        bad = sorted(set(surface) - set(SURFACES))
        if bad:
            raise BadInputError(f"surface: expected one of {list(SURFACES)}, got {bad}")
    else:
        surface = pd.Series("snow", index=table.index)
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
    else:
        c_sd = np.full(len(table), float(default_c_xr_sd))
    if require_outcome:
        y = pd.to_numeric(table[outcome], errors="coerce").to_numpy(float)
        if not np.all(np.isfinite(y)):
            raise BadInputError(f"{outcome}: expected finite numbers, got missing or non-numeric")
    else:
        y = np.full(len(table), np.nan)

    ids = table["tyre_id"].astype(str).to_numpy()
    uniq, row_tyre = np.unique(ids, return_inverse=True)
    key = pd.Series(list(zip(ids, surface, strict=True)))
    if key.duplicated().any():
        raise BadInputError(
            f"fleet table: expected one row per tyre_id and surface, got duplicates "
            f"{key[key.duplicated()].iloc[0]}"
        )
    tyre_type = np.zeros(len(uniq), int)
    tyre_c = np.zeros(len(uniq))
    tyre_sd = np.zeros(len(uniq))
    type_idx = types.map({t: i for i, t in enumerate(TYRE_TYPES)}).to_numpy(int)
    for k in range(len(uniq)):
        rows = row_tyre == k
        if len(set(type_idx[rows])) > 1 or np.ptp(c_xr[rows]) > 1e-9:
            raise BadInputError(
                f"tyre_id {uniq[k]}: expected one tyre_type and c_xr for all its rows, got several"
            )
        tyre_type[k], tyre_c[k], tyre_sd[k] = type_idx[rows][0], c_xr[rows][0], c_sd[rows][0]
    row_surface = surface.map({s: i for i, s in enumerate(SURFACES)}).to_numpy(int)
    if require_outcome:
        counts = pd.crosstab(surface.to_numpy(), types.to_numpy())
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
    return FleetData(
        tyre_ids=tuple(uniq.tolist()),
        tyre_type=tyre_type,
        c_xr=tyre_c,
        c_xr_sd=tyre_sd,
        row_tyre=np.asarray(row_tyre, int),
        row_surface=row_surface,
        y=y,
        outcome=outcome,
    )
