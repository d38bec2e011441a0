"""The fleet stage: the hierarchical fleet model on the tyre-set table, predictions per set.

:func:`fleet_table` turns the tyre-set table into the fleet-table contract (DESIGN.md): one row
per tyre set and surface on which its drives *observed* μ_max (ABS stops), from converged fits
of sets with a known tyre type. A μ_max that only repeats its prior is no observation and never
enters. :func:`run_fleet_stage` fits :func:`tyrebayes.fit_fleet` to it (what ``tyrebayes
fit-fleet`` does) and predicts every fitted set's friction on snow with its winter verdict
(:func:`tyrebayes.predict_friction`, :func:`tyrebayes.winter_verdict`). Outputs in ``fleet/``:
``fleet_table.csv``, ``fleet.nc``, ``predictions.parquet`` and the record.

Where sets carry a lateral estimate (c_y, :mod:`.lateral`), the fleet fit also learns each type's
ratio c_y / C_xr, and each set's prediction row carries the c_y a lane change of it would use:
``c_y_source`` ("measured": its own; "fleet_type_ratio": its type's ratio from the fleet fit times
its C_xr, for a set driven only straight; "" without either), ``c_y_mean``, ``c_y_sd``,
``c_y_q05``, ``c_y_q95`` [1/rad].
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from .._domain import SURFACES, TYRE_TYPES
from .._errors import BadInputError
from ..inference.tyre.adequacy import label_in_doubt
from .drive_stage import one_line
from .records import (
    read_record,
    record_path,
    stopping,
    unchanged,
    value_hash,
    write_parquet,
    write_record,
)
from .settings import RunSettings, configure_jax
from .worker_memory import peak_rss_mb

FLEET_DIR = "fleet"
#: Surface of the per-set predictions and warnings (the thesis' question: winter suitability).
PREDICTION_SURFACE = "snow"


#: The fleet table's columns as the fleet stage writes it.
FLEET_TABLE_COLUMNS = ("tyre_id", "tyre_type", "c_xr", "c_xr_sd", "c_y", "c_y_sd", "mu", "surface")


def fleet_table(tyre_sets: pd.DataFrame) -> pd.DataFrame:
    """Fleet-table rows (:data:`FLEET_TABLE_COLUMNS`) from the tyre-set table.

    One per converged set with a known type and surface where μ_max was observed, whose drives
    measured C_x (``c_x_measured``), and whose surface label the μ_max there does not put in
    doubt (:func:`~tyrebayes.inference.tyre.adequacy.label_in_doubt` of ``mu_<surface>_prior_sds``
    and ``mu_<surface>_label_log_bf``). A table without these columns keeps every such set.
    Each row carries the set's lateral estimate beside C_x (``c_y``, ``c_y_sd``; empty where its
    drives had no usable cornering, :mod:`.lateral`); a set with a lateral estimate and a
    measured C_x but no observed μ_max gets one row with an empty ``mu`` (on
    :data:`PREDICTION_SURFACE`), so that its ratio c_y / C_xr still reaches the fleet model.

    Examples
    --------
    >>> sets = pd.DataFrame([{"tyre_id": "a", "tyre_type": "winter", "converged": True,
    ...     "c_xr": 30.0, "c_xr_sd": 1.0, "c_y": 13.0, "c_y_sd": 1.3}])
    >>> fleet_table(sets)[["tyre_id", "c_y", "mu"]].to_dict("records")
    [{'tyre_id': 'a', 'c_y': 13.0, 'mu': nan}]
    """
    rows = []
    for rec in tyre_sets.to_dict("records"):
        if rec.get("tyre_type") not in TYRE_TYPES or not rec.get("converged", False):
            continue
        if not rec.get("c_x_measured", True):
            continue
        c_y = float(rec.get("c_y", np.nan))
        lateral = {
            "c_y": c_y if np.isfinite(c_y) else np.nan,
            "c_y_sd": float(rec.get("c_y_sd", np.nan)) if np.isfinite(c_y) else np.nan,
        }
        before = len(rows)
        for s in SURFACES:
            if label_in_doubt(
                rec.get(f"mu_{s}_prior_sds", 0.0), rec.get(f"mu_{s}_label_log_bf", -np.inf)
            ):
                continue
            if bool(rec.get(f"mu_{s}_observed", False)) and np.isfinite(rec.get(f"mu_{s}", np.nan)):
                rows.append(
                    {
                        "tyre_id": rec["tyre_id"],
                        "tyre_type": rec["tyre_type"],
                        "c_xr": rec["c_xr"],
                        "c_xr_sd": rec["c_xr_sd"],
                        **lateral,
                        "mu": rec[f"mu_{s}"],
                        "surface": s,
                    }
                )
        if len(rows) == before and np.isfinite(lateral["c_y"]):
            rows.append(
                {
                    "tyre_id": rec["tyre_id"],
                    "tyre_type": rec["tyre_type"],
                    "c_xr": rec["c_xr"],
                    "c_xr_sd": rec["c_xr_sd"],
                    **lateral,
                    "mu": np.nan,
                    "surface": PREDICTION_SURFACE,
                }
            )
    return pd.DataFrame(rows, columns=list(FLEET_TABLE_COLUMNS))


def _lateral_prediction(fit, rec: dict, tyre_type: str | None, seed: int) -> dict:
    """The set's c_y for the lane change: its own, else its type's fleet ratio times its C_xr."""
    from ..inference.fleet import has_lateral_ratio, lateral_ratio_draws

    c_y = float(rec.get("c_y", np.nan))
    if np.isfinite(c_y):
        sd = float(rec.get("c_y_sd", np.nan))
        z = 1.645 * sd / c_y  # the log-normal error the fleet model reads c_y_sd as
        return {"c_y_source": "measured", "c_y_mean": c_y, "c_y_sd": sd,
                "c_y_q05": c_y * np.exp(-z), "c_y_q95": c_y * np.exp(z)}  # fmt: skip
    if tyre_type is None or not has_lateral_ratio(fit):
        nan = float("nan")
        return {"c_y_source": "", "c_y_mean": nan, "c_y_sd": nan, "c_y_q05": nan, "c_y_q95": nan}
    k = lateral_ratio_draws(fit, tyre_type, 4000, seed=seed)
    rng = np.random.default_rng(seed)
    c_xr = np.maximum(float(rec["c_xr"]) + float(rec["c_xr_sd"]) * rng.standard_normal(k.size), 1.0)
    draws = k * c_xr
    lo, hi = np.quantile(draws, [0.05, 0.95])
    return {"c_y_source": "fleet_type_ratio", "c_y_mean": float(np.mean(draws)),
            "c_y_sd": float(np.std(draws)), "c_y_q05": float(lo), "c_y_q95": float(hi)}  # fmt: skip


def _predictions(fit, tyre_sets: pd.DataFrame, seed: int) -> pd.DataFrame:
    from ..decisions import winter_verdict
    from ..inference.fleet import predict_friction

    rows = []
    for rec in tyre_sets.to_dict("records"):
        tyre_type = rec.get("tyre_type") if rec.get("tyre_type") in TYRE_TYPES else None
        draws = predict_friction(
            fit, float(rec["c_xr"]), float(rec["c_xr_sd"]), tyre_type, PREDICTION_SURFACE, seed=seed
        )
        verdict = winter_verdict(draws)
        lo, hi = np.quantile(draws, [0.05, 0.95])
        rows.append(
            {
                "tyre_id": rec["tyre_id"],
                "tyre_type": rec.get("tyre_type", ""),
                "surface": PREDICTION_SURFACE,
                "mu_mean": float(np.mean(draws)),
                "mu_sd": float(np.std(draws)),
                "mu_q05": float(lo),
                "mu_q95": float(hi),
                "verdict": verdict.verdict,
                "p_below_mu_min": float(verdict.probability),
                "mu_min": float(verdict.mu_min),
                "reason": verdict.reason,
                "set_converged": bool(rec.get("converged", False)),
                **_lateral_prediction(fit, rec, tyre_type, seed),
            }
        )
    return pd.DataFrame(rows)


def run_fleet_stage(out_dir: str, tyre_sets: pd.DataFrame, settings: RunSettings) -> dict:
    """Fit the fleet model to the run's tyre-set table and predict per set (or skip); a record.

    A table the fleet model cannot take (too few sets with observed μ_max per type and surface)
    gives a failed record with the model's one-line reason; the per-set results stand.
    """
    start, cpu = time.perf_counter(), time.process_time()
    folder = Path(out_dir) / FLEET_DIR
    rec_path = record_path(folder, "fleet")
    config = settings.fleet_settings()
    table = fleet_table(tyre_sets)
    input_hash = value_hash(
        {
            "fleet_table": table.to_dict("list"),
            # every set's prediction reads its stiffness and, where it has one, its c_y
            "sets": tyre_sets[
                [c for c in ("tyre_id", "c_xr", "c_xr_sd", "c_y", "c_y_sd") if c in tyre_sets]
            ].to_dict("list")
            if len(tyre_sets)
            else {},
        }
    )
    old = read_record(rec_path)
    if unchanged(old, input_hash, config):
        return {**old, "skipped": True, "seconds": time.perf_counter() - start}
    record = {
        "item": "fleet",
        "input_hash": input_hash,
        "settings": config,
        "folder": str(folder),
        "rows": int(len(table)),
    }
    try:
        folder.mkdir(parents=True, exist_ok=True)
        from .._io import atomic_write_bytes

        atomic_write_bytes(folder / "fleet_table.csv", table.to_csv(index=False).encode())
        if not np.isfinite(table["mu"].to_numpy(float)).any():
            raise BadInputError(
                "no tyre set observed μ_max (ABS stops) with a known tyre type and a converged fit"
            )
        configure_jax(settings.jax_cache)
        from ..inference.fleet import fit_fleet

        method = "nuts" if len(table) <= 2000 else "svi"
        fit = fit_fleet(
            table, outcome="mu", method=method, seed=settings.seed, source="fleet-run tyre sets"
        )
        fit.save(folder / "fleet.nc")
        write_parquet(_predictions(fit, tyre_sets, settings.seed), folder / "predictions.parquet")
        record |= {
            "status": "done",
            "reason": "",
            "converged": bool(fit.converged),
            "method": method,
            "outputs": ["fleet_table.csv", "fleet.nc", "predictions.parquet"],
        }
    except Exception as err:  # noqa: BLE001 -- recorded: the per-set results stand without it
        if stopping():
            raise  # the interruption's failure, not the item's: no record, redone next run
        record |= {"status": "failed", "reason": one_line(err), "outputs": ["fleet_table.csv"]}
    record |= {
        "seconds": time.perf_counter() - start,
        "cpu_seconds": time.process_time() - cpu,
        "peak_rss_mb": peak_rss_mb(),
    }
    write_record(rec_path, record)
    return {**record, "skipped": False}
