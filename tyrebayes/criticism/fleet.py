"""Fleet-table criticism: the type-pooled baseline design and the candidate covariates.

Baseline (one surface): the outcome (e.g. snow friction) regressed on the centred inverse
stiffness z = 100 / C_xr - 2.5 (thesis Fig 6.1 abscissa) with an intercept per tyre type and a
slope that is partially pooled across types — a global slope plus per-type deviations whose prior
variance is small (a hierarchical prior with a fixed hyper-variance, which keeps the model
conjugate). The residual scale is shared by the types. This is the same family as the fleet model
of :mod:`tyrebayes.inference` (type-pooled regression on 1/C_xr); unlike it, C_xr enters as an
exact number (the measurement error of ``c_xr_sd`` attenuates the slope slightly), which is
what makes the exact, fast Normal-Inverse-Gamma posterior possible.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .._domain import TYRE_TYPES
from .._errors import BadInputError
from .scan import Candidate

# c_y and c_y_sd are a set's lateral estimate (the fleet model's ratio c_y / C_xr), not
# covariates of the outcome.
RESERVED = ("tyre_id", "tyre_type", "c_xr", "c_xr_sd", "c_y", "c_y_sd", "surface")
#: Prior variances (units of sigma^2 on the standardised scale).
PRIOR_VAR_INTERCEPT = 100.0
PRIOR_VAR_SLOPE = 25.0
#: Slope deviations of a type from the global slope: prior sd = 1 sigma per sd of z.
PRIOR_VAR_SLOPE_DEVIATION = 1.0


def select_rows(table: pd.DataFrame, outcome: str, surface: str | None) -> pd.DataFrame:
    """Validate a fleet table and keep the rows of one surface.

    Raises
    ------
    BadInputError
        Missing columns, unknown tyre types, non-positive stiffness, non-numeric or missing
        outcome, several surfaces without a choice, fewer than 6 rows.
    """
    for col in ("tyre_type", "c_xr", outcome):
        if col not in table.columns:
            raise BadInputError(
                f"fleet table: expected a column '{col}', got columns {list(table.columns)}"
            )
    if "surface" in table.columns:
        surfaces = sorted(table["surface"].astype(str).unique())
        if surface is None and len(surfaces) > 1:
            raise BadInputError(
                f"fleet table holds several surfaces {surfaces}: expected --surface NAME"
            )
        if surface is not None:
            if surface not in surfaces:
                raise BadInputError(f"surface: expected one of {surfaces}, got '{surface}'")
            table = table[table["surface"].astype(str) == surface]
    elif surface is not None:
        raise BadInputError(f"surface: expected a 'surface' column for '{surface}', got none")
    table = table.reset_index(drop=True)
    bad_types = sorted(set(table["tyre_type"].astype(str)) - set(TYRE_TYPES))
    if bad_types:
        raise BadInputError(f"tyre_type: expected values in {list(TYRE_TYPES)}, got {bad_types}")
    for col in ("c_xr", outcome):
        if not pd.api.types.is_numeric_dtype(table[col]):
            raise BadInputError(f"{col}: expected numbers, got dtype {table[col].dtype}")
        if not np.all(np.isfinite(table[col].to_numpy(dtype=float))):
            raise BadInputError(f"{col}: expected finite values in every row, got NaN or inf")
    if np.any(table["c_xr"].to_numpy(dtype=float) <= 0):
        raise BadInputError("c_xr: expected positive stiffness values, got a value <= 0")
    if len(table) < 6:
        raise BadInputError(f"fleet table: expected at least 6 rows, got {len(table)}")
    return table


def _standardise(v: np.ndarray) -> tuple[np.ndarray, float, float]:
    finite = v[np.isfinite(v)]
    mean = float(finite.mean())
    sd = float(finite.std())
    return (v - mean) / (sd if sd > 0 else 1.0), mean, (sd if sd > 0 else 1.0)


def baseline_design(
    table: pd.DataFrame, outcome: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, list[str]]:
    """Standardised outcome, baseline design, prior variances, outcome scale, column names."""
    y, _, y_scale = _standardise(table[outcome].to_numpy(dtype=float))
    z = 100.0 / table["c_xr"].to_numpy(dtype=float) - 2.5
    z_std, _, _ = _standardise(z)
    types = [t for t in TYRE_TYPES if (table["tyre_type"] == t).any()]
    cols, prior, names = [], [], []
    for t in types:
        cols.append((table["tyre_type"] == t).to_numpy(dtype=float))
        prior.append(PRIOR_VAR_INTERCEPT)
        names.append(f"intercept[{t}]")
    cols.append(z_std)
    prior.append(PRIOR_VAR_SLOPE)
    names.append("slope")
    if len(types) > 1:
        for t in types:
            cols.append((table["tyre_type"] == t).to_numpy(dtype=float) * z_std)
            prior.append(PRIOR_VAR_SLOPE_DEVIATION)
            names.append(f"slope_dev[{t}]")
    return y, np.column_stack(cols), np.array(prior), y_scale, names


def type_onehot(table: pd.DataFrame) -> np.ndarray:
    """One-hot tyre-type indicators (columns of the types present)."""
    types = [t for t in TYRE_TYPES if (table["tyre_type"] == t).any()]
    return np.column_stack([(table["tyre_type"] == t).to_numpy(dtype=float) for t in types])


def candidates_from_table(table: pd.DataFrame, outcome: str) -> list[Candidate]:
    """Every other column as a candidate: numeric ones standardised, categorical ones one-hot.

    Categorical columns need 2 to max(2, n // 3) levels (identifiers are not candidates); their
    columns are contrasts against the most frequent level. Constant columns are skipped.
    """
    n = len(table)
    out: list[Candidate] = []
    for col in table.columns:
        if col in RESERVED or col == outcome:
            continue
        series = table[col]
        if pd.api.types.is_bool_dtype(series):
            series = series.astype(float)
        if pd.api.types.is_numeric_dtype(series):
            v = series.to_numpy(dtype=float)
            finite = v[np.isfinite(v)]
            if finite.size < 3 or np.unique(finite).size < 2:
                continue
            v_std, _, sd = _standardise(v)
            out.append(Candidate(col, "numeric", v_std[:, None], np.array([sd]), (col,)))
            continue
        levels = series.dropna().astype(str)
        counts = levels.value_counts()
        if not 2 <= counts.size <= max(2, n // 3):
            continue
        ref = str(counts.index[0])
        others = [str(level) for level in counts.index[1:]]
        s = series.astype(str)
        missing = series.isna().to_numpy()
        cols = np.column_stack([(s == lev).to_numpy(dtype=float) for lev in others])
        cols[missing] = np.nan
        out.append(
            Candidate(
                col,
                "categorical",
                cols,
                np.ones(len(others)),
                tuple(f"{lev} vs {ref}" for lev in others),
            )
        )
    return out
