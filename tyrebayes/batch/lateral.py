"""A tyre set's lateral estimate in a fleet run: one lateral fit per drive, combined per set.

The fleet model learns the per-type ratio k = c_y / C_xr from the sets whose drives cornered
(:mod:`tyrebayes.inference.fleet.model`); this module gives each set its c_y.

Per drive, not per set: the drive stage holds the log (the set stage reads only windows
tables, so a set is refitted without its logs), the lateral model's nuisances (steering and a_y
offsets, roll, relaxation) belong to one drive and one sensor mounting, and the time derivatives
of its equations do not run across two logs. So :func:`drive_lateral` fits each drive and the
set stage combines the drives' posteriors (:func:`combine_drive_laterals`). A drive-summary
table's lateral work can be put on its sets' combined axle c_y (:func:`with_drive_cornering`:
what ``fit-wear`` does with one). A drive's fit is
the batch lateral fit (:func:`tyrebayes.inference.lateral.fit_lateral`, MAP + Laplace, as
``fit-tyre`` does), or, for a fast run, the in-car estimator's state after the drive's last
block (:mod:`tyrebayes.inference.online.lateral`: the batch model to fifth order in the tyre
curve, on the equations' sufficient statistics; milliseconds where the batch fit takes seconds,
and within one batch sd of it on 7 of the 8 independent cornering drives,
``benchmarks/results/online_lateral.json``).

The quantity is the car's normalised cornering stiffness c_y = sqrt(c_y_front · c_y_rear)
[1/rad over the static axle load], the geometric mean of the axles': a drive measures the
understeer gradient (the axles' difference) well and their split poorly, while their common
level is what the type relation C_y = k · C_xr describes (one c_y on both axles,
:mod:`tyrebayes.inference.vmax`). Its posterior is close to log-normal; a drive gives its log
mean and log-sd, and the set's is the product of the drives' Gaussians in log c_y with the prior
counted once: precision Σ 1/s_d² − (D − 1)/s_0², s_0 the prior's log-sd of c_y
(``LateralPriors.c_y_log_sd`` / √2, the axles' priors being independent).
"""

from __future__ import annotations

import math

import numpy as np

#: The drive summary's lateral columns (:func:`drive_lateral`).
DRIVE_LATERAL_COLUMNS = (
    "c_y",
    "c_y_log_sd",
    "c_y_front",
    "c_y_rear",
    "lateral_cornering_s",
    "lateral_reason",
)
#: The tyre-set table's lateral columns (:func:`combine_drive_laterals`).
SET_LATERAL_COLUMNS = ("c_y", "c_y_sd", "c_y_log_sd", "c_y_drives", "lateral_reason")


def _none(reason: str, cornering_s: float = float("nan")) -> dict:
    return {
        "c_y": float("nan"),
        "c_y_log_sd": float("nan"),
        "c_y_front": float("nan"),
        "c_y_rear": float("nan"),
        "lateral_cornering_s": cornering_s,
        "lateral_reason": reason,
    }


def lateral_off() -> dict:
    """The drive summary's lateral values of a run without lateral fits
    (``RunSettings(lateral=False)``).

    Examples
    --------
    >>> lateral_off()["lateral_reason"]
    'lateral: not fitted (the run was started without lateral fits)'
    """
    return _none("lateral: not fitted (the run was started without lateral fits)")


#: A drive's lateral fit: the batch fit, or the in-car estimator's moments (module docstring).
LATERAL_METHODS = ("laplace", "moments")


def drive_lateral(
    frame, vehicle, surface: str, *, method: str = "laplace", seed: int = 0, source: str = ""
) -> dict:
    """One drive's c_y (log-normal summary) from its lateral fit, or NaN with the reason.

    Parameters
    ----------
    frame : pandas.DataFrame
        The validated stream's frame (``ValidatedStream.data``).
    vehicle : Vehicle
    surface : str
        The drive's surface (the centre of the lateral fit's μ_y prior).
    method : str
        ``"laplace"`` (the batch lateral fit) or ``"moments"`` (the in-car estimator over the
        drive, :data:`LATERAL_METHODS`).
    seed : int
        Randomness of the Laplace draws.
    source : str
        The log's path (the lateral fit's provenance).

    Returns
    -------
    dict
        :data:`DRIVE_LATERAL_COLUMNS`: ``c_y`` = exp(mean log sqrt(c_f c_r)) [1/rad],
        ``c_y_log_sd`` (its posterior log-sd), the axles' posterior means, the seconds of
        cornering, and ``lateral_reason`` ("" when usable; else no usable cornering, not
        identified, not converged or not adequate, in one line).

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from tyrebayes import load_vehicle
    >>> t = np.arange(0, 30, 0.01)
    >>> f = pd.DataFrame({"time": t, "yaw_rate": 0 * t, "ay": 0 * t,
    ...                   "speed_reference": 20 + 0 * t, "steering_wheel_angle": 0 * t})
    >>> drive_lateral(f, load_vehicle("compact_fwd"), "dry")["lateral_reason"]
    'lateral: no usable cornering: 0.0 s with |a_y| > 1 m/s² above 8 m/s (need 15 s)'
    """
    from ..inference.lateral import NoCornering, cornering_observations, fit_lateral

    if method not in LATERAL_METHODS:
        raise ValueError(f"method: expected one of {LATERAL_METHODS}, got {method!r}")
    try:
        obs = cornering_observations(frame, vehicle)
    except NoCornering as err:
        return _none(str(err).splitlines()[0])
    seconds = float(obs.cornering_seconds)
    if method == "moments":
        return _by_moments(obs, surface, seconds)
    fit = fit_lateral(
        obs, "laplace", surface=surface, seed=seed, inputs=(source,) if source else ()
    )
    if not fit.identified:
        return _none(
            "lateral: not identified: the cornering did not narrow the understeer gradient to "
            "half its prior's spread",
            seconds,
        )
    if fit.unusable_reason():
        return _none(f"lateral: {fit.unusable_reason()}", seconds)
    c_f, c_r = fit.draws("c_y_front"), fit.draws("c_y_rear")
    log_c = 0.5 * (np.log(c_f) + np.log(c_r))
    return {
        "c_y": float(np.exp(np.mean(log_c))),
        "c_y_log_sd": float(np.std(log_c)),
        "c_y_front": float(np.mean(c_f)),
        "c_y_rear": float(np.mean(c_r)),
        "lateral_cornering_s": seconds,
        "lateral_reason": "",
    }


def _by_moments(obs, surface: str, seconds: float) -> dict:
    """:func:`drive_lateral` by the in-car estimator's state after the drive's last block."""
    from ..inference.online.lateral import online_lateral
    from ..inference.online.lateral_blocks import lateral_blocks

    estimate = online_lateral(lateral_blocks(obs), surface=surface).estimate
    if not bool(estimate.converged):
        return _none(estimate.reason(), seconds)
    # The batch fit's rule: K contracted. A car also waits for 4 minutes of VIF batches before
    # it shows an interval; a drive's fit is judged as the batch fit is, by K's contraction.
    if not estimate.k_contracted:
        return _none(
            "lateral: not identified: the cornering did not narrow the understeer gradient to "
            "half its prior's spread",
            seconds,
        )
    rows = [estimate.names.index("c_y_front"), estimate.names.index("c_y_rear")]
    mean = np.asarray(estimate.mean)[rows]
    cov = np.asarray(estimate.cov)[np.ix_(rows, rows)]
    return {
        "c_y": float(np.exp(mean.mean())),
        "c_y_log_sd": float(0.5 * math.sqrt(max(cov.sum(), 0.0))),
        "c_y_front": float(np.exp(mean[0] + 0.5 * cov[0, 0])),
        "c_y_rear": float(np.exp(mean[1] + 0.5 * cov[1, 1])),
        "lateral_cornering_s": seconds,
        "lateral_reason": "",
    }


def _prior_log_sd() -> float:
    from ..inference.lateral import LateralPriors

    return LateralPriors().c_y_log_sd / math.sqrt(2.0)


def combine_drive_laterals(drives: list[dict]) -> dict:
    """A tyre set's c_y from its drives' (:func:`drive_lateral` values; module docstring).

    Parameters
    ----------
    drives : list of dict
        Each with ``c_y`` and ``c_y_log_sd`` (NaN, None or missing where the drive had none)
        and ``lateral_reason``.

    Returns
    -------
    dict
        :data:`SET_LATERAL_COLUMNS`: ``c_y`` [1/rad] (the combined log-normal's median),
        ``c_y_sd`` = c_y · ``c_y_log_sd`` (the fleet table's standard error, read back as a
        relative error), ``c_y_drives`` (drives that contributed) and ``lateral_reason`` (""
        with an estimate; else why none, with the first drive's reason).

    Examples
    --------
    >>> one = {"c_y": 16.5, "c_y_log_sd": 0.1, "lateral_reason": ""}
    >>> out = combine_drive_laterals([one, one])
    >>> round(out["c_y"], 3), out["c_y_drives"], round(out["c_y_log_sd"], 4)
    (16.5, 2, 0.0722)
    >>> combine_drive_laterals([{"lateral_reason": "lateral: no usable cornering"}])["c_y_drives"]
    0
    """
    # A drive record read back from its JSON file holds None where the drive had no estimate.
    drives = [
        {**d, "c_y": _number(d.get("c_y")), "c_y_log_sd": _number(d.get("c_y_log_sd"))}
        for d in drives
    ]
    used = [d for d in drives if np.isfinite(d["c_y"]) and d["c_y_log_sd"] > 0]
    if not used:
        reasons = [str(d.get("lateral_reason") or "") for d in drives]
        first = next((r for r in reasons if r), "no lateral estimate")
        return {
            "c_y": float("nan"),
            "c_y_sd": float("nan"),
            "c_y_log_sd": float("nan"),
            "c_y_drives": 0,
            "lateral_reason": f"none of {len(drives)} drive(s) gave c_y (first: {first})",
        }
    m = np.log([d["c_y"] for d in used])
    prec = 1.0 / np.square([d["c_y_log_sd"] for d in used])
    prior_prec = 1.0 / _prior_log_sd() ** 2
    prior_mean = math.log(_prior_median())
    extra = len(used) - 1
    total = float(prec.sum() - extra * prior_prec)
    mean_num = float((prec * m).sum() - extra * prior_prec * prior_mean)
    if total <= prec.max():
        # The prior correction can only tighten the sharpest drive's posterior so far; below it
        # the drives' log-normal summaries are not what the correction assumes: keep the product.
        total, mean_num = float(prec.sum()), float((prec * m).sum())
    log_mean, log_sd = mean_num / total, 1.0 / math.sqrt(total)
    c_y = math.exp(log_mean)
    return {
        "c_y": c_y,
        "c_y_sd": c_y * log_sd,
        "c_y_log_sd": log_sd,
        "c_y_drives": len(used),
        "lateral_reason": "",
    }


def combined_cornering(drives: list[dict]):
    """The axles' c_y of a tyre set's drives, for the wear evidence's lateral work, or None.

    The level is :func:`combine_drive_laterals`'s c_y; the split is the drives' mean of
    log(c_y_front / c_y_rear) weighted by their precision, each axle the level times the split's
    square root up or down. The log-sd adds to the level's that of half the split's mean (the
    drives' scatter about it over the number of drives; the level's own where one drive gave
    it).

    Parameters
    ----------
    drives : list of dict
        Each with :data:`DRIVE_LATERAL_COLUMNS` (a drive summary's row).

    Returns
    -------
    CorneringStiffness or None
        ``source`` ``"drive_lateral"``; None when no drive gave c_y.

    Examples
    --------
    >>> one = {"c_y": 20.0, "c_y_log_sd": 0.1, "c_y_front": 16.0, "c_y_rear": 25.0,
    ...        "lateral_reason": ""}
    >>> c = combined_cornering([one, one])
    >>> round(c.front_per_rad, 1), round(c.rear_per_rad, 1), c.source
    (16.1, 25.2, 'drive_lateral')
    >>> combined_cornering([{"lateral_reason": "lateral: no usable cornering"}]) is None
    True
    """
    from ..streams.cornering_stiffness import CorneringStiffness

    level = combine_drive_laterals(drives)
    if not level["c_y_drives"]:
        return None
    used = [
        d
        for d in drives
        if np.isfinite(_number(d.get("c_y")))
        and _number(d.get("c_y_log_sd")) > 0
        and _number(d.get("c_y_front")) > 0
        and _number(d.get("c_y_rear")) > 0
    ]
    if not used:
        return None
    split = np.log([_number(d["c_y_front"]) / _number(d["c_y_rear"]) for d in used])
    weight = 1.0 / np.square([_number(d["c_y_log_sd"]) for d in used])
    mean_split = float(np.sum(weight * split) / np.sum(weight))
    split_sd = (
        float(np.sqrt(np.sum(weight * (split - mean_split) ** 2) / np.sum(weight) / len(used)))
        if len(used) > 1
        else level["c_y_log_sd"]
    )
    c_y, half = level["c_y"], math.exp(mean_split / 2.0)
    log_sd = math.hypot(level["c_y_log_sd"], split_sd / 2.0)
    return CorneringStiffness(c_y * half, c_y / half, log_sd, "drive_lateral")


def with_drive_cornering(table):
    """A drive-summary table's lateral work put on its drives' own c_y, and a one-line note.

    Per tyre set (``tyre_set_id``; the whole table without it), :func:`combined_cornering` of
    its drives' lateral estimates replaces the c_y the lateral work was computed with
    (:func:`tyrebayes.streams.wear_evidence_table.with_cornering`); a set none of whose drives
    gave c_y keeps its own. The note says how many sets took theirs ("" for a table without
    the lateral columns).

    Parameters
    ----------
    table : pandas.DataFrame
        A fleet run's drive summaries (wear evidence and :data:`DRIVE_LATERAL_COLUMNS`).

    Returns
    -------
    tuple of (pandas.DataFrame, str)

    Examples
    --------
    >>> import pandas as pd
    >>> table = pd.DataFrame({"work_y_front_j": [100.0, 100.0], "work_y_rear_j": [50.0, 50.0],
    ...     "cornering_stiffness_front_per_rad": [16.5, 16.5],
    ...     "cornering_stiffness_rear_per_rad": [16.5, 16.5],
    ...     "cornering_stiffness_log_sd": [0.5, 0.5],
    ...     "tyre_set_id": ["a", "b"], "c_y": [20.0, None], "c_y_log_sd": [0.1, None],
    ...     "c_y_front": [16.5, None], "c_y_rear": [24.0, None],
    ...     "lateral_reason": ["", "lateral: no usable cornering"]})
    >>> out, note = with_drive_cornering(table)
    >>> note
    "c_y from the drives' lateral estimates (1 of 2 tyre set(s))"
    >>> out["cornering_stiffness_source"].tolist()
    ['drive_lateral', 'type_prior']
    """
    from ..streams.wear_evidence_table import with_cornering

    needed = ("work_y_front_j", "cornering_stiffness_front_per_rad", "c_y_front")
    if not all(c in table for c in needed):
        return table, ""
    sets = table["tyre_set_id"].astype(str) if "tyre_set_id" in table else None
    keys = sets.unique().tolist() if sets is not None else [None]
    done = 0
    for key in keys:
        rows = np.ones(len(table), dtype=bool) if key is None else (sets == key).to_numpy()
        drives = table.loc[rows, [c for c in DRIVE_LATERAL_COLUMNS if c in table]]
        cornering = combined_cornering(drives.to_dict("records"))
        if cornering is not None:
            table = with_cornering(table, cornering, rows)
            done += 1
    if not done:
        return table, "no drive of the table gave c_y: its lateral work keeps the c_y it had"
    return table, f"c_y from the drives' lateral estimates ({done} of {len(keys)} tyre set(s))"


def _number(value) -> float:
    """A float, NaN for None (JSON's null) or anything that is not a finite number."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        return float("nan")
    return x if math.isfinite(x) else float("nan")


def _prior_median() -> float:
    from ..inference.lateral import LateralPriors

    return LateralPriors().c_y_median
