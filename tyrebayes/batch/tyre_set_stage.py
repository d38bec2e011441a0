"""The per-tyre-set stage: the joint fit of all drives of one tyre set, from their windows tables.

All drives of a set share its C_xr; each surface its μ_max
(:func:`tyrebayes.inference.stack_drives` + :func:`tyrebayes.inference.fit_tyre`, the same fit
as the demo's multi-drive sets). Its c_y combines the lateral fits its drives' records carry
(:mod:`.lateral`). :func:`fit_tyre_set` writes ``tyre_sets/ID.fit.nc``
(:func:`tyrebayes.load_fit` reads it), ``tyre_sets/ID.row.parquet`` (one row of the tyre-set
table, :func:`tyre_set_row`) and the record; it reads only windows tables, so a set is refitted
without its logs.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import pandas as pd

from .._domain import SURFACES
from .._errors import BadInputError
from .drive_stage import DRIVES_DIR, one_line
from .lateral import combine_drive_laterals
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
from .windows import drives_from_windows
from .worker_memory import WORKER, release_free_memory

TYRE_SETS_DIR = "tyre_sets"


def set_file_name(tyre_set_id: str) -> str:
    """A file-safe name for a tyre set id (its hash keeps distinct ids distinct)."""
    import hashlib

    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", tyre_set_id)[:60]
    return f"{safe}-{hashlib.sha256(tyre_set_id.encode()).hexdigest()[:8]}"


# Padded sizes per octave of a tyre-set fit's windows. A set's fit costs about its padded
# length: powers of two (one size per octave) paid up to twice the work, 1/ln 2 = 1.44x on
# average for lengths spread evenly on a log scale. Each size is one compilation of the fit
# (shared through the cache) and one reload of its programs where a worker's shape changes
# (seconds), so a fleet's many sets amortise four sizes per octave where one set would not;
# padding adds less than a quarter of the work.
FIT_SIZES_PER_OCTAVE = 4


def pad_size(n: int) -> int:
    """Padded number of windows of a tyre-set fit: at least 256, else the next size on a grid
    of :data:`FIT_SIZES_PER_OCTAVE` sizes per octave
    (:func:`~tyrebayes.inference.tyre.data.bucket_size`)."""
    from ..inference.tyre.data import bucket_size

    return max(256, bucket_size(n, FIT_SIZES_PER_OCTAVE))


def tyre_set_row(
    tyre_set_id: str,
    tyre_type: str,
    fit,
    n_drives: int,
    n_windows: int,
    lateral: dict | None = None,
) -> dict:
    """One row of the tyre-set table from a :class:`~tyrebayes.inference.tyre.fit.TyreFit`.

    Columns: ``tyre_id``, ``tyre_type``, ``c_xr``, ``c_xr_sd``, per surface ``mu_<surface>``,
    ``mu_<surface>_sd``, ``mu_<surface>_observed`` (NaN / False for surfaces without drives),
    ``mu_<surface>_prior_sds`` (an observed μ_max's distance from the surface's prior median in
    prior sds, :attr:`~tyrebayes.inference.tyre.adequacy.Adequacy.mu_prior_sds`; NaN where not
    observed), ``mu_<surface>_label_log_bf`` (the log Bayes factor of the grippier surface whose
    prior predicts that μ_max best over the label,
    :attr:`~tyrebayes.inference.tyre.adequacy.Adequacy.mu_likelier_surface`; NaN where not
    observed or on the grippiest surface),
    ``converged``, ``adequate``, ``adequacy_reasons``, ``c_x_measured`` (the drives measured
    C_x: :attr:`~tyrebayes.inference.tyre.adequacy.Adequacy.measures_c_x`), ``r_hat_max``,
    ``ess_bulk_min``,
    ``divergences``, ``optimiser_result``, ``method``, ``model``, ``n_drives``, ``n_windows``,
    ``n_abs_windows``, and the set's lateral estimate beside C_x
    (:data:`~tyrebayes.batch.lateral.SET_LATERAL_COLUMNS`: ``c_y`` [1/rad], ``c_y_sd``,
    ``c_y_log_sd``, ``c_y_drives``, ``lateral_reason``; NaN / 0 with the reason where its
    drives had no usable cornering), from ``lateral``
    (:func:`~tyrebayes.batch.lateral.combine_drive_laterals`; None: no drive was fitted).
    """
    summary = fit.summary()
    diag = fit.diagnostics
    row = {
        "tyre_id": tyre_set_id,
        "tyre_type": tyre_type,
        "c_xr": float(summary["c_xr"]["mean"]),
        "c_xr_sd": float(summary["c_xr"]["sd"]),
    }
    by_surface = summary["mu_max_by_surface"]
    for s in SURFACES:
        mu = by_surface.get(s)
        row[f"mu_{s}"] = float(mu["mean"]) if mu else float("nan")
        row[f"mu_{s}_sd"] = float(mu["sd"]) if mu else float("nan")
        row[f"mu_{s}_observed"] = bool(mu["observed"]) if mu else False
        row[f"mu_{s}_prior_sds"] = fit.adequacy.mu_prior_sds.get(s, float("nan"))
        row[f"mu_{s}_label_log_bf"] = fit.adequacy.mu_likelier_surface.get(s, ("", float("nan")))[1]
    row |= {
        "converged": bool(fit.converged),
        "adequate": bool(diag.adequate),
        "adequacy_reasons": " | ".join(diag.adequacy_reasons),
        "c_x_measured": bool(fit.adequacy.measures_c_x),
        "r_hat_max": float(diag.r_hat_max),
        "ess_bulk_min": float(diag.ess_bulk_min),
        "divergences": int(diag.divergences),
        "optimiser_result": str(diag.optimiser_result),
        "method": str(diag.method),
        "model": str(fit.model),
        "n_drives": int(n_drives),
        "n_windows": int(n_windows),
        "n_abs_windows": int(summary["n_abs_windows"]),
    }
    row |= combine_drive_laterals([]) if lateral is None else lateral
    return row


def fit_tyre_set(
    tyre_set_id: str,
    tyre_type: str,
    drives: list[dict],
    out_dir: str,
    settings: RunSettings,
) -> dict:
    """Fit one tyre set jointly over its finished drives (or skip it); returns its record.

    Parameters
    ----------
    tyre_set_id, tyre_type : str
        The set and its type (``""`` when the manifest does not say).
    drives : list of dict
        Records of the set's finished drives (:func:`~.drive_stage.process_drive`), in manifest
        order: their ``drive_id`` and ``windows_hash`` key the fit.
    out_dir : str
        The run's output folder.
    settings : RunSettings
    """
    rss_at_start, dropped = WORKER.start("tyre_set", settings.memory_budget_mb)
    start, cpu = time.perf_counter(), time.process_time()
    configure_jax(settings.jax_cache)
    name = set_file_name(tyre_set_id)
    folder = Path(out_dir) / TYRE_SETS_DIR
    rec_path = record_path(folder, name)
    config = settings.tyre_set_settings()
    input_hash = _input_hash(tyre_set_id, tyre_type, drives)
    old = read_record(rec_path)
    if unchanged(old, input_hash, config):
        return {**old, "skipped": True, "seconds": time.perf_counter() - start}
    record = {
        "item": "tyre_set",
        "tyre_set_id": tyre_set_id,
        "input_hash": input_hash,
        "settings": config,
        "folder": str(folder),
        "drives": [d["drive_id"] for d in drives],
    }
    try:
        table = _windows_of(drives, out_dir)
        dropped |= WORKER.keep_one_fit_shape(pad_size(len(table)))
        record |= _fit_and_write(tyre_set_id, tyre_type, drives, table, folder, settings)
    except Exception as err:  # noqa: BLE001 -- a set that cannot be fitted is recorded
        if stopping():
            raise  # the interruption's failure, not the item's: no record, redone next run
        record |= {"status": "failed", "reason": one_line(err), "outputs": []}
    record |= {
        "seconds": time.perf_counter() - start,
        "cpu_seconds": time.process_time() - cpu,
        "peak_rss_mb": WORKER.finish("tyre_set", rss_at_start, dropped),
        "rss_mb_at_start": rss_at_start,
        "programs_dropped": dropped,
    }
    write_record(rec_path, record)
    release_free_memory()  # the worker idles, or starts its next task, without it
    return {**record, "skipped": False}


def _input_hash(tyre_set_id: str, tyre_type: str, drives: list[dict]) -> str:
    """What the set's fit depends on besides the settings: its id and type, its drives'
    windows tables (by hash) and their lateral fits."""
    return value_hash(
        {
            "tyre_set_id": tyre_set_id,
            "tyre_type": tyre_type,
            "drives": [(d["drive_id"], d["windows_hash"]) for d in drives],
            "lateral": [d.get("lateral") for d in drives],
        }
    )


def _windows_of(drives: list[dict], out_dir: str) -> pd.DataFrame:
    """The windows tables of a set's drives, in their order, as one table.

    Raises
    ------
    BadInputError
        No drive of the set was processed.
    """
    if not drives:
        raise BadInputError("no drive of this tyre set was processed")
    drives_dir = Path(out_dir) / DRIVES_DIR
    return pd.concat(
        [pd.read_parquet(drives_dir / f"{d['drive_id']}.windows.parquet") for d in drives],
        ignore_index=True,
    )


def _fit_and_write(
    tyre_set_id: str,
    tyre_type: str,
    drives: list[dict],
    table: pd.DataFrame,
    folder: Path,
    settings: RunSettings,
) -> dict:
    """Fit the set jointly over its drives' windows ``table``; write its fit file and table
    row into ``folder`` (``tyre_sets/``); return the fields of a done set's record."""
    from ..inference.result import provenance
    from ..inference.tyre.data import stack_drives
    from ..inference.tyre.fit import fit_tyre
    from ..inference.tyre.model import TyrePriors

    windows, surfaces = drives_from_windows(table)
    n = int(len(table))
    obs = stack_drives(windows, surfaces, pad_to=pad_size(n))
    fit = fit_tyre(
        obs,
        priors=TyrePriors().with_load_sensitivity() if settings.load_sensitivity else None,
        method=settings.method,
        model=settings.model,
        seed=settings.seed,
        pointwise=settings.pointwise,
    )
    fit = _with_provenance(fit, provenance, tyre_set_id, drives, settings)
    name = set_file_name(tyre_set_id)
    fit.save(folder / f"{name}.fit.nc")
    lateral = combine_drive_laterals([d.get("lateral") or {} for d in drives])
    row = tyre_set_row(tyre_set_id, tyre_type, fit, len(drives), n, lateral)
    write_parquet(pd.DataFrame([row]), folder / f"{name}.row.parquet")
    return {
        "status": "done",
        "reason": "",
        "converged": row["converged"],
        "outputs": [f"{name}.fit.nc", f"{name}.row.parquet"],
    }


def _with_provenance(fit, provenance, tyre_set_id, drives, settings):
    import dataclasses

    return dataclasses.replace(
        fit,
        provenance=provenance(
            settings.method,
            settings.model,
            tuple(d.get("path", d["drive_id"]) for d in drives),
            tyre_set_id=tyre_set_id,
            seed=settings.seed,
            load_sensitivity=settings.load_sensitivity,
            source="fleet-run windows tables",
        ),
    )


def tyre_set_table(out_dir: str, records: list[dict]) -> pd.DataFrame:
    """The tyre-set table: the rows of the sets whose fit is done, in the order given."""
    folder = Path(out_dir) / TYRE_SETS_DIR
    rows = [
        pd.read_parquet(folder / f"{set_file_name(r['tyre_set_id'])}.row.parquet")
        for r in records
        if r.get("status") == "done"
    ]
    if not rows:
        return pd.DataFrame(columns=["tyre_id", "tyre_type", "c_xr", "c_xr_sd"])
    return pd.concat(rows, ignore_index=True)


__all__ = ["fit_tyre_set", "pad_size", "set_file_name", "tyre_set_row", "tyre_set_table"]
