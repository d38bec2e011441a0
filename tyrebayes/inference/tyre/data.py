"""Observations for the per-tyre model: short-window averages of slip and normalised force.

Why windows: a one-hour 100 Hz drive has 360,000 samples, each with slip noise of the same size
as the slip itself. Averaging over ~0.25 s keeps the slow true slip (it follows the driver's
pedal) while dividing the white sensor noise variance by the window length, and it reduces the
data the sampler touches by the same factor. The remaining noise in *both* slip and force is
handled by the errors-in-variables likelihood of :mod:`tyrebayes.inference.tyre.model`.

Arrays are padded to a fixed bucket size with a mask so that new data of the same bucket reuse
the compiled model.
"""

from __future__ import annotations

from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ..._domain import SURFACES
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

# Length of the blocks whose slips share an offset in the model [s]: slow slip and force errors
# (tyre radius drifting with temperature, IMU bias instability, road grade the features did not
# remove) change over tens of seconds, the driver's force over 1-10 s, so within 5 s the force
# still varies and the slow errors hardly do.
BLOCK_S = 5.0


class TyreObservations(eqx.Module):
    """Window-averaged observations of one tyre set (the driven axle), padded with a mask.

    Attributes
    ----------
    slip : Float[Array, "n"]
        Measured longitudinal slip σ_x of the driven axle [-] (window mean).
    rho : Float[Array, "n"]
        Measured normalised force ρ_x = F_x/F_z of the driven axle [-] (window mean).
    slip_sd, rho_sd : Float[Array, "n"]
        Standard deviation of the measurement noise of each window mean [-].
    temperature_c : Float[Array, "n"]
        Tyre temperature estimate for the window [°C].
    load_change : Float[Array, "n"]
        The driven axle's load over its static load, minus 1 [-] (window mean of
        :attr:`tyrebayes.streams.StreamFeatures.load_change_driven`; 0 where not known): the
        model's C_x follows it through the tyre's load sensitivity.
    at_limit : Bool[Array, "n"]
        The window is an ABS (force-at-the-limit) window: its slip is not measurable (all four
        wheels cycle) and its force observes μ_max directly.
    neighbour_slip : Float[Array, "n"]
        Mean measured slip of the adjacent windows [-]. The current model (slip regressed on force)
        does not read it; window selection still drops windows without a neighbour.
    slip_weight : Float[Array, "n"]
        Weight of the window's slip in the likelihood [-]: 1 from :func:`stack_drives`; the fits
        set it to the drive's share of independent information in its windows, 1/(variance
        inflation) of its slip errors (:mod:`.window_correlation`).
    imu_gain_log_sd : Float[Array, "n"]
        Log-scale uncertainty of the IMU scale factor the stream pipeline divided the window's
        drive's forces by [-] (:func:`tyrebayes.streams.nuisances.imu_gain_correction`; 0 where
        the IMU was left as it is). One value per drive, repeated over its windows like
        ``slip_weight``; the model widens that drive's force-gain prior by it.
    rho_score, rho_score_slope : Float[Array, "n"]
        d/dρ log p(ρ_obs) and its derivative [1/-, 1/-²] at each window's measured force, with p
        the density of the measured forces of the window's drive at the window's noise (slip
        windows only; 0 for ABS windows): :func:`.force_density.force_density_score`. They give
        the model E[ρ_true | ρ_obs] and Var[ρ_true | ρ_obs] without assuming the shape of the
        force distribution.
    drive_index : Int[Array, "n"]
        Which drive (day) the window belongs to: 0 … n_drives − 1.
    block_index : Int[Array, "n"]
        Which block of :data:`BLOCK_S` seconds of its drive the window lies in, numbered across
        drives (0 … n − 1; ABS windows and padding too, where nothing reads it). The model lets
        each block's slip have its own small offset (:mod:`.tyre_model`).
    surface_index : Int[Array, "n"]
        Index into ``surfaces``.
    mask : Bool[Array, "n"]
        False for padding.
    n_drives : int
        Number of drives (static).
    surfaces : tuple of str
        Surface names in index order (static).
    """

    slip: Float[Array, "n"]
    rho: Float[Array, "n"]
    slip_sd: Float[Array, "n"]
    rho_sd: Float[Array, "n"]
    temperature_c: Float[Array, "n"]
    load_change: Float[Array, "n"]
    neighbour_slip: Float[Array, "n"]
    slip_weight: Float[Array, "n"]
    imu_gain_log_sd: Float[Array, "n"]
    rho_score: Float[Array, "n"]
    rho_score_slope: Float[Array, "n"]
    at_limit: Bool[Array, "n"]
    drive_index: Int[Array, "n"]
    block_index: Int[Array, "n"]
    surface_index: Int[Array, "n"]
    mask: Bool[Array, "n"]
    n_drives: int = eqx.field(static=True)
    surfaces: tuple[str, ...] = eqx.field(static=True)

    @property
    def n_used(self) -> int:
        """Number of real (unpadded) windows."""
        return int(np.asarray(self.mask).sum())

    @property
    def n_limit(self) -> int:
        """Number of real ABS (at-the-limit) windows."""
        return int(np.asarray(self.mask & self.at_limit).sum())

    @property
    def n_surfaces(self) -> int:
        return len(self.surfaces)


def bucket_size(n: int, per_octave: int = 8) -> int:
    """Padded length for n windows: 64, or the next size on a grid of ``per_octave`` sizes per
    octave (a power of two).

    Data of similar size share one compiled model, and padding wastes less than 1/per_octave of
    the work (powers of two wasted up to half: a one-hour drive of ~8,300 windows padded to
    16,384).
    """
    if n <= 64:
        return 64
    step = 1 << max(0, int(np.floor(np.log2(n))) - int(np.log2(per_octave)))
    return int(-(-n // step) * step)


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
) -> dict[str, np.ndarray]:
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
        Further per-sample channels to average over the same samples (returned by name).

    Returns
    -------
    dict
        ``slip``, ``rho``, ``slip_sd``, ``rho_sd``, ``temperature_c``, ``time_s`` (the time of
        the window's centre) arrays, one entry per kept window, and ``neighbour_slip`` (and the
        ``also`` channels). The noise sd of a window mean of k samples is sd/√k.
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
    return out


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
) -> dict[str, np.ndarray]:
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
    dict
        As :func:`windowed_observations`, plus ``load_change`` (the driven axle's
        ΔF_z/F_z,static), ``at_limit`` (bool per window) and ``rho_score``,
        ``rho_score_slope`` (:func:`force_density_score` over all the drive's windows, 0 for ABS).
    """
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
    correlation = max(1.0, features.smoothing_s * features.sample_rate_hz)
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
    window_rho_total = windows.pop("rho_total")
    score, score_slope = _slip_window_scores(
        windows["rho"], windows["rho_sd"], np.zeros(len(windows["rho"]), bool)
    )
    # Only windows where the axles push (total force >= 0): a negative total may be engine drag on
    # the driven axle or friction brakes on all four wheels, and the split between the axles is
    # not observable without a brake signal. Guessing it puts a kink into ρ_x(σ_x) at zero force,
    # which the model could only read as curvature (a spuriously low μ_max and a high C_x).
    pushing = window_rho_total >= PUSHING_MARGIN
    slip_windows = {k: v[pushing] for k, v in windows.items()}
    slip_windows["rho_score"] = score[pushing]
    slip_windows["rho_score_slope"] = score_slope[pushing]
    slip_windows["at_limit"] = np.zeros(len(slip_windows["slip"]), dtype=bool)

    dt = 1.0 / features.sample_rate_hz
    window = max(1, int(round(window_s / dt)))
    fx, fz = features.fx_axle_n, features.fz_axle_n
    rho_total = np.sum(fx, axis=1) / np.sum(fz, axis=1)
    valid = (
        features.valid & np.isfinite(rho_total) & np.all(np.isfinite(features.wheel_vx_mps), axis=1)
    )
    oscillation = wheel_oscillation(features.wheel_vx_mps, valid, window, features.sample_rate_hz)
    rho_mean, counts = window_means(rho_total, valid, window)
    sd_ok = valid & np.isfinite(features.rho_driven_sd)
    rho_sd, _ = window_means(features.rho_driven_sd, sd_ok, window)
    sample_temperature = np.broadcast_to(np.asarray(temperature_c, dtype=float), valid.shape)
    limit_temperature, _ = window_means(sample_temperature, np.ones_like(valid), window)
    limit_time = window_centres(features.time_s, window, len(rho_mean))
    limit_load, _ = window_means(np.nan_to_num(features.load_change_driven), valid, window, counts)
    enough = counts >= 0.8 * window
    baseline = nanmedian(np.where(enough, oscillation, np.nan)) if enough.any() else np.nan
    candidate = (
        enough
        & np.isfinite(oscillation)
        & (oscillation > abs_oscillation_factor * baseline)
        & (rho_mean < -abs_min_decel)
    )
    at_limit = _below_run_peak(_inner_runs(candidate, min_run=abs_min_windows), rho_mean)
    m = int(at_limit.sum())
    factor = np.sqrt(min(1.0, correlation / window))
    limit_windows = {
        "slip": np.zeros(m),
        "rho": rho_mean[at_limit],
        "slip_sd": np.ones(m),
        "rho_sd": np.nan_to_num(rho_sd[at_limit], nan=0.01) * factor,
        "temperature_c": limit_temperature[at_limit],
        "load_change": limit_load[at_limit],
        "time_s": limit_time[at_limit],
        "neighbour_slip": np.zeros(m),
        "rho_score": np.zeros(m),
        "rho_score_slope": np.zeros(m),
        "at_limit": np.ones(m, dtype=bool),
    }
    out = {k: np.concatenate([slip_windows[k], limit_windows[k]]) for k in limit_windows}
    # One value for the drive: the uncertainty of the IMU scale factor its forces were divided by.
    out["imu_gain_log_sd"] = np.full(len(out["slip"]), features.nuisances.ax_gain.applied_log_sd)
    return out


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


def stack_drives(
    drives: Sequence[dict[str, np.ndarray]],
    surfaces: Sequence[str],
    *,
    pad_to: int | None = None,
) -> TyreObservations:
    """Combine the windows of several drives of one tyre set into padded observations.

    Parameters
    ----------
    drives : sequence of dict
        Outputs of :func:`windowed_observations` or :func:`observations_from_features`, one per
        drive. Their ``rho_score`` and ``rho_score_slope`` are used if present, else computed
        from the drive's slip windows (:func:`force_density_score`). Windows are kept in the
        order given (time order: the slip-weight estimate reads neighbours in the array).
    surfaces : sequence of str
        Surface of each drive, from ``SURFACES``.
    pad_to : int, optional
        Padded length; default :func:`bucket_size` (8 sizes per octave).
    """
    if len(drives) != len(surfaces):
        raise BadInputError(
            f"tyre observations: expected one surface per drive ({len(drives)}), "
            f"got {len(surfaces)}"
        )
    if not drives:
        raise BadInputError("tyre observations: expected at least one drive, got none")
    unknown = [s for s in surfaces if s not in SURFACES]
    if unknown:
        raise BadInputError(f"surface: expected one of {SURFACES}, got {unknown[0]!r}")
    used_surfaces = tuple(s for s in SURFACES if s in surfaces)
    keys = (
        "slip",
        "rho",
        "slip_sd",
        "rho_sd",
        "temperature_c",
        "load_change",
        "neighbour_slip",
        "at_limit",
    )
    parts = {k: [] for k in (*keys, "rho_score", "rho_score_slope", "imu_gain_log_sd")}
    drive_idx, surface_idx, block_idx = [], [], []
    n_blocks = 0
    for d, (drive, surface) in enumerate(zip(drives, surfaces, strict=True)):
        m = len(drive["slip"])
        # Windows without times (hand-made drives) count BLOCK_S / 0.25 s windows to a block.
        times = np.asarray(drive.get("time_s", 0.25 * np.arange(m)), dtype=float)
        blocks = np.unique(np.floor(times / BLOCK_S).astype(np.int64), return_inverse=True)[1]
        block_idx.append(n_blocks + blocks.reshape(-1))
        n_blocks += int(blocks.max()) + 1 if m else 0
        # Hand-made drives may leave out what the stream pipeline measures: no ABS windows, no
        # IMU rescaling, the static load.
        drive = {
            "at_limit": np.zeros(m, dtype=bool),
            "imu_gain_log_sd": np.zeros(m),
            "load_change": np.zeros(m),
            **drive,
        }
        parts["imu_gain_log_sd"].append(np.asarray(drive["imu_gain_log_sd"], dtype=float))
        for k in keys:
            parts[k].append(np.asarray(drive[k], dtype=bool if k == "at_limit" else float))
        if "rho_score" in drive:
            score, score_slope = drive["rho_score"], drive["rho_score_slope"]
        else:
            score, score_slope = _slip_window_scores(
                parts["rho"][-1], parts["rho_sd"][-1], parts["at_limit"][-1]
            )
        parts["rho_score"].append(np.asarray(score, dtype=float))
        parts["rho_score_slope"].append(np.asarray(score_slope, dtype=float))
        drive_idx.append(np.full(m, d))
        surface_idx.append(np.full(m, used_surfaces.index(surface)))
    n = sum(len(p) for p in parts["slip"])
    if n < 10:
        raise BadInputError(f"tyre observations: expected at least 10 usable windows, got {n}")
    size = pad_to or bucket_size(n)
    if size < n:
        raise BadInputError(f"tyre observations: pad_to expected ≥ {n}, got {size}")

    def pad(values: np.ndarray, fill) -> np.ndarray:
        return np.concatenate([values, np.full(size - n, fill, dtype=values.dtype)])

    cat = {k: np.concatenate(v) for k, v in parts.items()}
    return TyreObservations(
        slip=jnp.asarray(pad(cat["slip"], 0.0)),
        rho=jnp.asarray(pad(cat["rho"], 0.0)),
        slip_sd=jnp.asarray(pad(cat["slip_sd"], 1.0)),
        rho_sd=jnp.asarray(pad(cat["rho_sd"], 1.0)),
        temperature_c=jnp.asarray(pad(cat["temperature_c"], 20.0)),
        load_change=jnp.asarray(pad(cat["load_change"], 0.0)),
        neighbour_slip=jnp.asarray(pad(cat["neighbour_slip"], 0.0)),
        slip_weight=jnp.ones(size),
        imu_gain_log_sd=jnp.asarray(pad(cat["imu_gain_log_sd"], 0.0)),
        rho_score=jnp.asarray(pad(cat["rho_score"], 0.0)),
        rho_score_slope=jnp.asarray(pad(cat["rho_score_slope"], 0.0)),
        at_limit=jnp.asarray(pad(cat["at_limit"], False)),
        drive_index=jnp.asarray(pad(np.concatenate(drive_idx), 0)),
        block_index=jnp.asarray(pad(np.concatenate(block_idx), 0)),
        surface_index=jnp.asarray(pad(np.concatenate(surface_idx), 0)),
        mask=jnp.asarray(np.arange(size) < n),
        n_drives=len(drives),
        surfaces=used_surfaces,
    )


def windows_from_stream(
    path,
    vehicle,
    *,
    surface: str = "dry",
    temperature_c: float | None = None,
    ambient_c: float | None = None,
    window_s: float = 0.25,
    channel_map: dict[str, str] | None = None,
) -> dict[str, np.ndarray]:
    """Read, validate and window one stream file: the windows of one drive, in time order.

    The stream pipeline of ``fit-tyre`` (:func:`observations_from_stream` stacks its result) and
    of the online estimator.

    Parameters
    ----------
    path : path-like or ValidatedStream
        Stream file (CSV, Parquet or MDF4) in the DESIGN.md contract, or a stream already read
        and validated against ``vehicle`` (``channel_map`` then unused).
    vehicle : Vehicle or str
        Vehicle parameters, a preset name (``suv_rav4``) or a TOML path.
    surface : str
        Road surface of the drive, one of :data:`SURFACES` (sets the μ_max prior).
    temperature_c : float, optional
        A fixed tyre temperature for the whole drive [°C]. Default: the driven tyres' temperature
        estimated sample by sample from the drive's speed and loads
        (:func:`~tyrebayes.streams.tyre_temperature.features_tyre_temperature`), starting cold.
    ambient_c : float, optional
        Ambient temperature [°C] for that estimate; default the mean ``ambient_temperature``
        column, else 20 °C.
    window_s : float
        Window length [s].

    Raises
    ------
    BadInputError
        Missing file, missing columns, unknown vehicle or too few usable windows.
    """
    from ..._domain import load_vehicle
    from ...physics.vehicle import Vehicle
    from ...streams import ValidatedStream, compute_features, read_stream, validate_stream
    from ...streams.tyre_temperature import features_tyre_temperature

    if not isinstance(vehicle, Vehicle):
        try:
            vehicle = load_vehicle(vehicle)
        except ValueError as err:
            raise BadInputError(str(err).splitlines()[0]) from None
    if surface not in SURFACES:
        raise BadInputError(f"surface: expected one of {SURFACES}, got {surface!r}")
    if isinstance(path, ValidatedStream):
        # Already read and validated by the caller (fit-tyre reads the flags and the frame too).
        stream = path
    else:
        stream = validate_stream(read_stream(path, channel_map), vehicle)
    if ambient_c is None:
        ambient_c = stream.mean_ambient_c()
    features = compute_features(stream, vehicle)
    if temperature_c is None:
        temperature_c = features_tyre_temperature(features, ambient_c=ambient_c)
    return observations_from_features(features, temperature_c=temperature_c, window_s=window_s)


def observations_from_stream(
    path,
    vehicle,
    *,
    surface: str = "dry",
    temperature_c: float | None = None,
    ambient_c: float | None = None,
    window_s: float = 0.25,
    channel_map: dict[str, str] | None = None,
) -> TyreObservations:
    """Read, validate and window one stream file for :func:`tyrebayes.inference.fit_tyre`.

    :func:`windows_from_stream` (same parameters and errors), stacked as one drive.
    """
    windows = windows_from_stream(
        path,
        vehicle,
        surface=surface,
        temperature_c=temperature_c,
        ambient_c=ambient_c,
        window_s=window_s,
        channel_map=channel_map,
    )
    return stack_drives([windows], [surface])
