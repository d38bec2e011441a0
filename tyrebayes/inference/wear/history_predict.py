"""Predictions of a drive-history wear fit: tread depth against distance, km to 3 and 1.6 mm.

Per posterior draw: the current set's wear rate per axle is γ exp(κ (T − 20)) times the history's
friction work per km of that axle, longitudinal plus lateral (eq. 4.19a + b, the lateral work at
its posterior scale: the cornering stiffness' error), all drives, each weighted by the distance
it stands for; the
current depth is the pair's initial depth (posterior with readings, the new-tyre prior without)
minus what the history wore off it. Future driving is assumed like the history's and no further
rotation is assumed. The high-wear warning compares the car set's worn mass per 1000 km with the
ADAC convoy figure of the tyre type (``tyrebayes/data/wear_by_tyre_type.csv``, mid-range); the
command turns the ratio's draws into a warning with :func:`tyrebayes.decisions.high_wear_warning`.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from ..._errors import BadInputError
from ..._resources import data_dir
from ...physics.wear import TreadGeometry
from ..result import Fit
from ..summary import summarize
from .changepoint import TyreChanges
from .history import DriveHistory, TreadReadings
from .history_fit import NEW_DEPTH_MM, NEW_DEPTH_SD_MM, tread_loss

#: Tread limits of the predictions [mm]: a common replacement advice and the legal minimum (EU).
LIMITS_MM = (3.0, 1.6)


def reference_wear_g_per_1000km(tyre_type: str) -> float:
    """Mid-range ADAC convoy wear of a tyre type, per car set per 1000 km [g]."""
    table = pd.read_csv(data_dir() / "wear_by_tyre_type.csv")
    rows = table[table["tyre_type"] == tyre_type]
    if rows.empty:
        raise ValueError(
            f"tyre_type: expected one of {sorted(set(table['tyre_type']))}, got {tyre_type!r}"
        )
    lo = rows["wear_min_g_per_1000km"].dropna()
    hi = rows["wear_max_g_per_1000km"].dropna()
    return float((lo.mean() + hi.mean()) / 2.0)


#: Axle positions of the per-axle results, in order.
AXLE_NAMES = ("front", "rear")


@dataclasses.dataclass(frozen=True)
class WearHistoryPrediction:
    """Predictions of a drive-history wear fit (:func:`wear_history_predictions`), as draws.

    Per-axle arrays are (draws, 2) in :data:`AXLE_NAMES` order, of the tyre pair on that axle
    now; :meth:`to_dict` summarises them into ``fit-wear --json``'s object.

    Attributes
    ----------
    gamma_mm3_per_j : ndarray, shape (draws,)
        Abrasability γ [mm³/J].
    gamma_work_mm3_per_j : ndarray, shape (draws,)
        γ times the evidence's work-scale error: wear per joule of the evidence's work [mm³/J].
    kappa_per_k : ndarray, shape (draws,), or None
        Temperature sensitivity κ of γ [1/K] (extended model); None for the baseline.
    lateral_source : str
        Where the cornering stiffness behind the lateral work came from.
    lateral_log_sd : float
        Log-sd of the lateral work's scale (the cornering stiffness') [-].
    lateral_share_of_work : tuple of float
        The lateral work's share of each axle's friction work in the history [-].
    lateral_work_scale : ndarray, shape (draws, 2), or None
        Posterior scale of each axle's lateral work [-] (None: not in the fit).
    wear_mm_per_km : ndarray, shape (draws, 2)
        Tread worn per km of driving like the history's [mm/km].
    depth_now_mm : ndarray, shape (draws, 2)
        Tread depth after the last drive [mm].
    km_to_limit_km : ndarray, shape (len(limits_mm), draws)
        Distance from the last drive until the first axle reaches each limit [km] (negative:
        already below).
    depth_curve_km_ahead : ndarray, shape (m,)
        Distances ahead of the last drive [km].
    depth_curve_quantiles_mm : ndarray, shape (3, m)
        The 5, 50 and 95 % quantiles of the lower axle's depth there [mm].
    g_per_1000km_car_set : ndarray, shape (draws,)
        Worn rubber mass of the car set (four tyres) per 1000 km [g].
    reference_g_per_1000km : float
        The tyre type's mid-range ADAC convoy wear [g per car set per 1000 km].
    tyre_type : str
        The type of that reference.
    tyre_changes : TyreChanges
        The history's detected tyre changes.
    tyre_change_odometer_km : ndarray, shape (changes,)
        The start of the drive of each change [km].
    n_drives : int
        Drives in the history.
    history_km : float
        Distance the history stands for [km].
    limits_mm : tuple of float
        The tread limits of ``km_to_limit_km`` [mm] (default :data:`LIMITS_MM`).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> draws = lambda mean, shape: mean * (1 + 0.05 * rng.standard_normal(shape))
    >>> none = TyreChanges(np.zeros(0, int), (), np.zeros(0), np.zeros(0), 3.0, 0.01)
    >>> pred = WearHistoryPrediction(
    ...     gamma_mm3_per_j=draws(0.02, 50), gamma_work_mm3_per_j=draws(0.02, 50),
    ...     kappa_per_k=None, lateral_source="type_prior", lateral_log_sd=0.5,
    ...     lateral_share_of_work=(0.4, 0.6), lateral_work_scale=None,
    ...     wear_mm_per_km=draws(1e-4, (50, 2)), depth_now_mm=draws(7.0, (50, 2)),
    ...     km_to_limit_km=draws(40000.0, (2, 50)),
    ...     depth_curve_km_ahead=np.linspace(0.0, 60000.0, 13),
    ...     depth_curve_quantiles_mm=np.tile(np.linspace(7.0, 1.0, 13), (3, 1)),
    ...     g_per_1000km_car_set=draws(100.0, 50), reference_g_per_1000km=110.0,
    ...     tyre_type="summer", tyre_changes=none, tyre_change_odometer_km=np.zeros(0),
    ...     n_drives=40, history_km=15000.0)
    >>> out = pred.to_dict()
    >>> list(out)[:4], round(out["wear_mm_per_1000km"]["front"]["mean"], 2)
    (['gamma', 'gamma_work', 'lateral_work', 'wear_mm_per_1000km'], 0.1)
    >>> pred.wear_over_reference.shape, out["km_to_1_6mm"]["already_below"]
    ((50,), False)
    """

    gamma_mm3_per_j: np.ndarray
    gamma_work_mm3_per_j: np.ndarray
    kappa_per_k: np.ndarray | None
    lateral_source: str
    lateral_log_sd: float
    lateral_share_of_work: tuple[float, float]
    lateral_work_scale: np.ndarray | None
    wear_mm_per_km: np.ndarray
    depth_now_mm: np.ndarray
    km_to_limit_km: np.ndarray
    depth_curve_km_ahead: np.ndarray
    depth_curve_quantiles_mm: np.ndarray
    g_per_1000km_car_set: np.ndarray
    reference_g_per_1000km: float
    tyre_type: str
    tyre_changes: TyreChanges
    tyre_change_odometer_km: np.ndarray
    n_drives: int
    history_km: float
    limits_mm: tuple[float, ...] = LIMITS_MM

    def __post_init__(self) -> None:
        if np.shape(self.km_to_limit_km)[0] != len(self.limits_mm):
            raise ValueError(
                f"km_to_limit_km: expected {len(self.limits_mm)} rows (one per limit), got "
                f"{np.shape(self.km_to_limit_km)[0]}"
            )

    @property
    def wear_over_reference(self) -> np.ndarray:
        """Draws of the car set's worn mass over the type's reference [-], for
        :func:`tyrebayes.decisions.high_wear_warning`."""
        return self.g_per_1000km_car_set / self.reference_g_per_1000km

    def to_dict(self) -> dict:
        """``fit-wear --json``'s predictions: each quantity's ``{"mean", "sd", "hdi_90"}``.

        Keys: ``gamma``, ``gamma_work``, ``lateral_work``, ``kappa`` (extended),
        ``wear_mm_per_1000km`` and ``depth_now_mm`` (front, rear), ``km_to_3mm`` and
        ``km_to_1_6mm`` (with ``already_below``), ``depth_curve``, ``g_per_1000km_car_set``,
        ``wear_over_reference``, ``tyre_changes``, ``n_drives``, ``history_km``.
        """
        out: dict = {
            "gamma": summarize(self.gamma_mm3_per_j).to_dict(),
            "gamma_work": summarize(self.gamma_work_mm3_per_j).to_dict(),
            "lateral_work": self._lateral_dict(),
        }
        if self.kappa_per_k is not None:
            out["kappa"] = summarize(self.kappa_per_k).to_dict()
        out["wear_mm_per_1000km"] = {
            name: summarize(1000.0 * self.wear_mm_per_km[:, a]).to_dict()
            for a, name in enumerate(AXLE_NAMES)
        }
        out["depth_now_mm"] = {
            name: summarize(self.depth_now_mm[:, a]).to_dict() for a, name in enumerate(AXLE_NAMES)
        }
        for limit, km in zip(self.limits_mm, self.km_to_limit_km, strict=True):
            key = f"km_to_{limit:g}mm".replace(".", "_")
            out[key] = {
                **summarize(np.maximum(km, 0.0)).to_dict(),
                "already_below": bool(np.mean(km < 0) > 0.5),
            }
        q = self.depth_curve_quantiles_mm
        out["depth_curve"] = {
            "km_ahead": self.depth_curve_km_ahead.tolist(),
            "q05_mm": q[0].tolist(),
            "q50_mm": q[1].tolist(),
            "q95_mm": q[2].tolist(),
        }
        out["g_per_1000km_car_set"] = summarize(self.g_per_1000km_car_set).to_dict()
        out["wear_over_reference"] = {
            **summarize(self.wear_over_reference).to_dict(),
            "reference_g_per_1000km": self.reference_g_per_1000km,
            "tyre_type": self.tyre_type,
        }
        out["tyre_changes"] = self._changes_list()
        out["n_drives"] = self.n_drives
        out["history_km"] = self.history_km
        return out

    def _lateral_dict(self) -> dict:
        """The lateral work's part: the stiffness' source and log-sd, shares, posterior scale."""
        out = {
            "cornering_stiffness_source": self.lateral_source,
            "cornering_stiffness_log_sd": float(self.lateral_log_sd),
            "share_of_work": dict(zip(AXLE_NAMES, self.lateral_share_of_work, strict=True)),
        }
        if self.lateral_work_scale is not None:
            q = self.lateral_work_scale
            out["scale"] = {name: summarize(q[:, a]).to_dict() for a, name in enumerate(AXLE_NAMES)}
        return out

    def _changes_list(self) -> list[dict]:
        """Each tyre change: drive index, odometer [km], change type and its probability."""
        changes = self.tyre_changes
        return [
            {
                "drive_index": int(k),
                "odometer_km": float(odo),
                "change_type": change_type,
                "probability": float(p),
            }
            for k, odo, change_type, p in zip(
                changes.index,
                self.tyre_change_odometer_km,
                changes.change_type,
                changes.probability,
                strict=True,
            )
        ]


def wear_history_predictions(
    fit: Fit,
    history: DriveHistory,
    readings: TreadReadings | None = None,
    *,
    tyre_type: str = "summer",
    geom: TreadGeometry | None = None,
    horizon_km: float = 60000.0,
    seed: int = 0,
) -> WearHistoryPrediction:
    """Predictive tread depth, distance to the limits and the high-wear ratio, as draws.

    Parameters
    ----------
    fit : Fit
        A drive-history wear fit (:func:`~tyrebayes.inference.wear.fit_wear_history`).
    history : DriveHistory
        The history it was fitted to.
    readings : TreadReadings, optional
        Its tread readings (unused: the fit's initial depths carry them); without readings in
        the fit the initial depths are the new-tyre prior's.
    tyre_type : str
        The type whose ADAC convoy wear is the high-wear reference.
    geom : TreadGeometry, optional
        Tread band (wear area, rubber density).
    horizon_km : float
        How far ahead the depth curve goes [km].
    seed : int
        Randomness of the new-tyre depths drawn without readings.

    Returns
    -------
    WearHistoryPrediction
        Its :meth:`~WearHistoryPrediction.to_dict` is ``fit-wear --json``'s object (without the
        command's keys); :attr:`~WearHistoryPrediction.wear_over_reference` the draws for
        :func:`tyrebayes.decisions.high_wear_warning`.

    Examples
    --------
    >>> pred = wear_history_predictions(fit, history, readings)  # doctest: +SKIP
    >>> pred.to_dict()["km_to_3mm"]["mean"]  # doctest: +SKIP
    """
    del readings  # the fit's initial depths carry them
    geom = TreadGeometry() if geom is None else geom
    history = as_fitted(history, fit)
    gamma = fit.draws("gamma_work")  # per joule of evidence work: what the history fixed
    has = fit.posterior.data_vars
    kappa = fit.draws("kappa") if "kappa" in has else None
    loss = _loss_per_drive(fit, history, gamma, kappa, geom)
    per_km = loss.sum(axis=1) / history.total_km  # mm per km per axle position
    depth_now = _depth_now(fit, history, loss, gamma.size, seed)
    km_to = np.stack(
        [np.min((depth_now - limit) / np.maximum(per_km, 1e-12), axis=1) for limit in LIMITS_MM]
    )
    ahead = np.linspace(0.0, horizon_km, 13)
    lowest = np.min(depth_now[:, None, :] - per_km[:, None, :] * ahead[None, :, None], axis=2)
    grams = 2.0 * 1000.0 * per_km.sum(axis=1) * geom.wear_area_mm2
    grams = grams * geom.rubber_density_g_per_cm3 / 1000.0  # car set, per 1000 km
    return WearHistoryPrediction(
        gamma_mm3_per_j=fit.draws("gamma"),
        gamma_work_mm3_per_j=gamma,
        kappa_per_k=kappa,
        lateral_source=history.lateral_source,
        lateral_log_sd=float(history.lateral_log_sd),
        lateral_share_of_work=_lateral_share(history),
        lateral_work_scale=fit.draws("lateral_work_scale") if "lateral_work_scale" in has else None,
        wear_mm_per_km=per_km,
        depth_now_mm=depth_now,
        km_to_limit_km=km_to,
        depth_curve_km_ahead=ahead,
        depth_curve_quantiles_mm=np.quantile(lowest, (0.05, 0.5, 0.95), axis=0),
        g_per_1000km_car_set=grams,
        reference_g_per_1000km=reference_wear_g_per_1000km(tyre_type),
        tyre_type=tyre_type,
        tyre_changes=history.changes,
        tyre_change_odometer_km=history.odometer_km[np.asarray(history.changes.index, int)],
        n_drives=history.n_drives,
        history_km=history.total_km,
    )


def as_fitted(history: DriveHistory, fit: Fit) -> DriveHistory:
    """``history`` as ``fit`` read it: its last drive's interval closed at the latest tread
    reading, and its tyre changes of the types the readings gave (the fit's attributes)."""
    attrs = fit.data.attrs
    history = history.through(float(attrs.get("history_end_km", history.end_km)))
    if "tyre_changes" not in attrs:
        return history
    fitted = fit.attr("tyre_changes")
    if fitted["drive_index"] != history.changes.index.tolist():
        raise BadInputError(
            f"wear predictions: expected the history the fit read (tyre changes at drives "
            f"{fitted['drive_index']}), got one with changes at {history.changes.index.tolist()}"
        )
    return history.with_change_types(tuple(fitted["change_type"]), fitted["probability"])


def _loss_per_drive(
    fit: Fit, history: DriveHistory, gamma: np.ndarray, kappa: np.ndarray | None, geom
) -> np.ndarray:
    """Tread lost per draw, drive and axle position (draws, n, 2) [mm per tyre].

    γ exp(κ (T − 20)) per joule of each drive's work, longitudinal plus lateral at its posterior
    scale q_a / s (eq. 4.19a + b), over the two tyres' wear area.
    """
    kappa = np.zeros_like(gamma) if kappa is None else kappa
    if "log_lateral_ratio" in fit.posterior.data_vars:
        log_ratio = fit.draws("log_lateral_ratio")  # (draws, 2): log q_a / s
    else:
        log_ratio = np.zeros((gamma.size, 2))
    return tread_loss(history, gamma, kappa, log_ratio, geom.wear_area_mm2)


def _depth_now(
    fit: Fit, history: DriveHistory, loss: np.ndarray, n_draws: int, seed: int
) -> np.ndarray:
    """Depth of the pairs on the axles after the last drive (draws, 2) [mm].

    Each pair's initial depth (the fit's posterior with readings, else the new-tyre prior)
    less what the history wore off it on whichever axle it sat.
    """
    rng = np.random.default_rng(seed)
    if "initial_depth_mm" in fit.posterior.data_vars:
        d0 = fit.draws("initial_depth_mm")
    else:
        d0 = NEW_DEPTH_MM + NEW_DEPTH_SD_MM * rng.standard_normal((n_draws, history.n_pairs))
    current = history.pair[-1]
    worn = np.zeros((n_draws, 2))
    for a, p in enumerate(current):
        on = history.pair == p  # (n, 2): intervals where pair p sat on each axle
        worn[:, a] = (loss * on[None, :, :]).sum(axis=(1, 2))
    return d0[:, current] - worn


def _lateral_share(history: DriveHistory) -> tuple[float, float]:
    """The lateral work's share of each axle's friction work over the history [-]."""
    return tuple(
        float(
            history.work_y_j[:, a].sum()
            / max(history.work_j[:, a].sum() + history.work_y_j[:, a].sum(), 1e-300)
        )
        for a in range(2)
    )
