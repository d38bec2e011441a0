"""One drive's windows: short-window averages of slip and normalised force, and ABS windows.

Why windows: see :mod:`tyrebayes.inference.tyre.data`. Re-exported by it.
"""

from __future__ import annotations

import numpy as np

from ..._errors import BadInputError
from ...streams.abs_detection import (
    _below_run_peak,
    _inner_runs,
    wheel_oscillation,
    window_counts,
    window_means,
)
from ...streams.order_stats import median, nanmedian
from .force_density import force_density_score
from .window_table import WindowTable


def window_centres(time_s: np.ndarray, window: int, n_blocks: int) -> np.ndarray:
    """Centre times of the first ``n_blocks`` blocks of ``window`` samples [s]."""
    dt = median(np.diff(time_s), overwrite_input=True) if len(time_s) > 1 else 0.0
    return np.asarray(time_s, dtype=float)[: n_blocks * window : window] + 0.5 * (window - 1) * dt


def _neighbour_mean(values: np.ndarray) -> np.ndarray:
    """Mean of the previous and next window (either alone at edges and gaps; NaN if neither)."""
    padded = np.concatenate([[np.nan], values, [np.nan]])
    neighbours = np.stack([padded[:-2], padded[2:]])
    valid = np.isfinite(neighbours)
    total = np.where(valid, neighbours, 0.0).sum(axis=0)
    count = valid.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def windowed_observations(
    time_s: np.ndarray,
    slip: np.ndarray,
    rho: np.ndarray,
    slip_sd: np.ndarray | float,
    rho_sd: np.ndarray | float,
    *,
    temperature_c: np.ndarray | float = 20.0,
    usable: np.ndarray | None = None,
    window_s: float = 0.25,
    min_fraction_valid: float = 0.8,
    correlation_samples: float = 1.0,
    also: dict[str, np.ndarray] | None = None,
) -> WindowTable:
    """Average per-sample slip and force over short windows (one drive).

    Parameters
    ----------
    time_s : ndarray
        Sample times [s] on a uniform base (NaN samples allowed in the signals).
    slip, rho : ndarray
        Per-sample driven-axle slip and normalised force [-].
    slip_sd, rho_sd : ndarray or float
        Per-sample white-noise standard deviations [-].
    temperature_c : ndarray or float
        Tyre temperature [°C].
    usable : ndarray of bool, optional
        Samples allowed into the fit (e.g. straight-line segments, no wheel spin on a split).
    window_s : float
        Window length [s].
    min_fraction_valid : float
        Windows with fewer valid samples than this fraction are dropped.
    correlation_samples : float
        Number of consecutive samples over which the noise is correlated (the smoothing window of
        the features); a mean of k samples then has noise sd·√(c/k) rather than sd/√k.
    also : dict of str to ndarray, optional
        Further per-sample channels to average over the same samples: those named as a column
        of :class:`WindowTable` (``load_change``) fill it, the others its ``extra``.

    Returns
    -------
    WindowTable
        ``slip``, ``rho``, ``slip_sd``, ``rho_sd``, ``temperature_c``, ``time_s`` (the time of
        the window's centre), one entry per kept window, and ``neighbour_slip`` (and the
        ``also`` channels). The noise sd of a window mean of k samples is sd/√k.

    Examples
    --------
    One minute at 100 Hz of a linear tyre (C_x = 30) with slip noise 1e-3:

    >>> t = np.arange(0.0, 60.0, 0.01)
    >>> rho = 0.1 + 0.05 * np.sin(t)
    >>> slip = rho / 30.0 + np.random.default_rng(0).normal(0.0, 1e-3, t.size)
    >>> windows = windowed_observations(t, slip, rho, slip_sd=1e-3, rho_sd=0.01)
    >>> len(windows), float(windows.slip_sd[0])
    (240, 0.0002)
    """
    time_s = np.asarray(time_s, dtype=float)
    n = len(time_s)
    if n < 2:
        raise BadInputError(f"tyre observations: expected at least 2 samples, got {n}")
    dt = median(np.diff(time_s), overwrite_input=True)
    window = max(1, int(round(window_s / dt)))
    arrays = {
        "slip": np.asarray(slip, dtype=float),
        "rho": np.asarray(rho, dtype=float),
        "slip_sd": np.broadcast_to(np.asarray(slip_sd, dtype=float), (n,)),
        "rho_sd": np.broadcast_to(np.asarray(rho_sd, dtype=float), (n,)),
        "temperature_c": np.broadcast_to(np.asarray(temperature_c, dtype=float), (n,)),
        **{name: np.asarray(values, dtype=float) for name, values in (also or {}).items()},
    }
    for name, arr in arrays.items():
        if arr.shape != (n,):
            raise BadInputError(f"tyre observations: {name} expected shape ({n},), got {arr.shape}")
    valid = np.ones(n, dtype=bool) if usable is None else np.asarray(usable, dtype=bool).copy()
    for arr in arrays.values():
        valid &= np.isfinite(arr)
    # Every channel is averaged over the same valid samples: one count per window serves all.
    counts = window_counts(valid, window)
    out = {name: window_means(arr, valid, window, counts)[0] for name, arr in arrays.items()}
    out["time_s"] = window_centres(time_s, window, len(counts))
    keep = counts >= max(1, int(np.ceil(min_fraction_valid * window)))
    out["neighbour_slip"] = _neighbour_mean(np.where(keep, out["slip"], np.nan))
    keep &= np.isfinite(out["neighbour_slip"])
    # Noise of a mean of k samples correlated over c samples: sd·√(c/k), at most sd.
    factor = np.sqrt(np.minimum(1.0, max(correlation_samples, 1.0) / np.maximum(counts, 1)))
    out = {k: v[keep] for k, v in out.items()}
    out["slip_sd"] = out["slip_sd"] * factor[keep]
    out["rho_sd"] = out["rho_sd"] * factor[keep]
    return WindowTable.from_dict(out)


# Slip windows need a total force of at least this [-]. Below zero the friction brakes act on
# every wheel, the free-rolling wheels that give V_x brake too, and the driven axle's measured
# slip is σ_driven − σ_free: read as traction it puts a kink at zero force. The total force is
# known to about ±0.01 (drag area ±20 % and rolling resistance ±30 % against the vehicle file:
# ±0.002-0.004 of ρ at 20 m/s; the road grade the features take from the IMU over 10 s and the
# IMU offset: ±0.005-0.01), so windows within two of those of zero may be braking. On drives from
# an independent generator the windows near zero force had measured slips well above the truth,
# those above 0.05 hardly.
PUSHING_MARGIN = 0.02


def observations_from_features(
    features,
    *,
    temperature_c: float | np.ndarray = 20.0,
    window_s: float = 0.25,
    abs_oscillation_factor: float = 5.0,
    abs_min_decel: float = 0.05,
    abs_min_windows: int = 4,
) -> WindowTable:
    """Windowed observations of one drive from :class:`tyrebayes.streams.StreamFeatures`.

    Two kinds of window enter the fit:

    * **slip windows**: windows of free rolling, traction and braking samples (straight or gently
      curving, no spin) whose mean total force is at least :data:`PUSHING_MARGIN`; the
      force is the driven axle's with the traction split. Braking windows are left out: the
      non-driven wheels that give V_x brake too, so the driven axle's measured slip there is
      σ_driven − σ_free, not σ_driven (:mod:`tyrebayes.streams.features`).
    * **ABS windows** (``at_limit``): braking windows whose wheel speeds oscillate the way ABS
      pressure modulation makes them (per-wheel speed relative to the four-wheel mean with a
      within-window sd above ``abs_oscillation_factor`` times the drive's median). All four
      wheels are then near their peak, so the *total* normalised force ΣF_x/ΣF_z (independent of
      the assumed brake balance) observes μ_max; their slip is not used.

    Parameters
    ----------
    features : StreamFeatures
        From :func:`tyrebayes.streams.compute_features`.
    temperature_c : float or ndarray
        Tyre temperature [°C]: one value for the drive, or one per sample of ``features``
        (:func:`tyrebayes.streams.tyre_temperature.features_tyre_temperature`, what
        :func:`observations_from_stream` uses); windows take its mean over their samples.
    window_s : float
        Window length [s].
    abs_oscillation_factor : float
        ABS detection threshold relative to the drive's median wheel-slip oscillation [-].
    abs_min_decel : float
        A window counts as braking if its total ρ_x is below −this [-].
    abs_min_windows : int
        An ABS event must last this many consecutive windows (ABS stops last seconds; road bumps
        shake the wheels for a fraction of one); its first and last window (partly outside the
        event) are dropped.

    Returns
    -------
    WindowTable
        As :func:`windowed_observations`, plus ``load_change`` (the driven axle's
        ΔF_z/F_z,static), ``at_limit`` (bool per window), ``rho_score``,
        ``rho_score_slope`` (:func:`force_density_score` over all the drive's windows, 0 for ABS)
        and ``imu_gain_log_sd``: the slip windows in time order, then the ABS windows.

    Examples
    --------
    >>> from tyrebayes import compute_features, load_vehicle, read_stream, validate_stream
    >>> from tyrebayes._resources import data_dir
    >>> vehicle = load_vehicle("suv_rav4")
    >>> df = read_stream(data_dir() / "comma2k19_rav4_segment.csv")
    >>> features = compute_features(validate_stream(df, vehicle), vehicle)
    >>> windows = observations_from_features(features, temperature_c=15.0)
    >>> len(windows), int(windows.at_limit.sum())
    (123, 0)
    """
    correlation = max(1.0, features.smoothing_s * features.sample_rate_hz)
    slip_windows = _slip_windows(features, temperature_c, window_s, correlation)
    limit_windows = _abs_windows(
        features,
        temperature_c,
        window_s,
        correlation,
        oscillation_factor=abs_oscillation_factor,
        min_decel=abs_min_decel,
        min_windows=abs_min_windows,
    )
    windows = WindowTable.concatenate([slip_windows, limit_windows])
    # One value for the drive: the uncertainty of the IMU scale factor its forces were divided by.
    return windows.replace(
        imu_gain_log_sd=np.full(len(windows), features.nuisances.ax_gain.applied_log_sd)
    )


def _slip_windows(
    features, temperature_c: float | np.ndarray, window_s: float, correlation: float
) -> WindowTable:
    """The slip windows of :func:`observations_from_features`: free rolling, traction and
    braking samples averaged over windows, kept where the total force is at least
    :data:`PUSHING_MARGIN`, with their force-density scores (``imu_gain_log_sd`` left out)."""
    from ...streams.segments import BRAKING, FREE_ROLLING, TRACTION

    # Samples are not selected on their own force: a sample whose noise takes the total force
    # below zero would drop out, so the windows kept near zero force would average only the
    # samples the noise pushed up (+0.021 to +0.023 on the window force near zero with doubled
    # noise, against +0.004 to +0.008 without the cut, on two drives; C_x did not move measurably
    # from the cut alone). Every sample of free rolling, traction and braking enters a
    # window, the force with the traction split throughout (continuous through zero), and the
    # selection is then made on the window's force, which the model conditions on anyway.
    usable = (
        features.valid & ~features.spin & np.isin(features.label, (FREE_ROLLING, TRACTION, BRAKING))
    )
    windows = windowed_observations(
        features.time_s,
        features.slip_driven,
        features.rho_driven_traction,
        features.slip_driven_sd,
        features.rho_driven_traction_sd,
        temperature_c=temperature_c,
        usable=usable,
        window_s=window_s,
        correlation_samples=correlation,
        also={
            "rho_total": features.rho_total_traction,
            "load_change": features.load_change_driven,
        },
    )
    # The density of the measured forces (for E[ρ_true | ρ_obs], tyre_model) is that of every
    # window: estimated on the kept ones only, it would fall off artificially at the cut.
    score, score_slope = _slip_window_scores(
        windows.rho, windows.rho_sd, np.zeros(len(windows), bool)
    )
    # Only windows where the axles push (total force >= 0): a negative total may be engine drag on
    # the driven axle or friction brakes on all four wheels, and the split between the axles is
    # not observable without a brake signal. Guessing it puts a kink into ρ_x(σ_x) at zero force,
    # which the model could only read as curvature (a spuriously low μ_max and a high C_x).
    pushing = windows.extra["rho_total"] >= PUSHING_MARGIN
    return windows.replace(
        rho_score=score,
        rho_score_slope=score_slope,
        at_limit=np.zeros(len(windows), bool),
        extra={},
    ).select(pushing)


def _abs_windows(
    features,
    temperature_c: float | np.ndarray,
    window_s: float,
    correlation: float,
    *,
    oscillation_factor: float,
    min_decel: float,
    min_windows: int,
) -> WindowTable:
    """The ABS windows of :func:`observations_from_features` (``at_limit``): their total force,
    its noise, temperature, load and time; slip 0 with sd 1 (not used), scores 0."""
    dt = 1.0 / features.sample_rate_hz
    window = max(1, int(round(window_s / dt)))
    fx, fz = features.fx_axle_n, features.fz_axle_n
    rho_total = np.sum(fx, axis=1) / np.sum(fz, axis=1)
    valid = (
        features.valid & np.isfinite(rho_total) & np.all(np.isfinite(features.wheel_vx_mps), axis=1)
    )
    rho_mean, counts = window_means(rho_total, valid, window)
    at_limit = _abs_detections(
        features,
        valid,
        window,
        rho_mean,
        counts,
        oscillation_factor=oscillation_factor,
        min_decel=min_decel,
        min_windows=min_windows,
    )
    sd_ok = valid & np.isfinite(features.rho_driven_sd)
    rho_sd, _ = window_means(features.rho_driven_sd, sd_ok, window)
    sample_temperature = np.broadcast_to(np.asarray(temperature_c, dtype=float), valid.shape)
    limit_temperature, _ = window_means(sample_temperature, np.ones_like(valid), window)
    limit_time = window_centres(features.time_s, window, len(rho_mean))
    limit_load, _ = window_means(np.nan_to_num(features.load_change_driven), valid, window, counts)
    m = int(at_limit.sum())
    factor = np.sqrt(min(1.0, correlation / window))
    return WindowTable(
        slip=np.zeros(m),
        rho=rho_mean[at_limit],
        slip_sd=np.ones(m),
        rho_sd=np.nan_to_num(rho_sd[at_limit], nan=0.01) * factor,
        temperature_c=limit_temperature[at_limit],
        time_s=limit_time[at_limit],
        neighbour_slip=np.zeros(m),
        load_change=limit_load[at_limit],
        at_limit=np.ones(m, dtype=bool),
        rho_score=np.zeros(m),
        rho_score_slope=np.zeros(m),
    )


def _abs_detections(
    features,
    valid: np.ndarray,
    window: int,
    rho_mean: np.ndarray,
    counts: np.ndarray,
    *,
    oscillation_factor: float,
    min_decel: float,
    min_windows: int,
) -> np.ndarray:
    """Which windows (of ``window`` samples) are ABS windows: braking harder than ``min_decel``
    with the wheels oscillating above ``oscillation_factor`` times the drive's median, inside a
    run of at least ``min_windows`` such windows, below the run's peak force."""
    oscillation = wheel_oscillation(features.wheel_vx_mps, valid, window, features.sample_rate_hz)
    enough = counts >= 0.8 * window
    baseline = nanmedian(np.where(enough, oscillation, np.nan)) if enough.any() else np.nan
    candidate = (
        enough
        & np.isfinite(oscillation)
        & (oscillation > oscillation_factor * baseline)
        & (rho_mean < -min_decel)
    )
    return _below_run_peak(_inner_runs(candidate, min_run=min_windows), rho_mean)


def _slip_window_scores(
    rho: np.ndarray, rho_sd: np.ndarray, at_limit: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`force_density_score` over one drive's slip windows; 0 for its ABS windows."""
    score, score_slope = np.zeros(len(rho)), np.zeros(len(rho))
    slip_windows = ~at_limit & np.isfinite(rho) & np.isfinite(rho_sd) & (rho_sd > 0)
    if slip_windows.sum() >= 2:
        score[slip_windows], score_slope[slip_windows] = force_density_score(
            rho[slip_windows], rho_sd[slip_windows]
        )
    return score, score_slope
