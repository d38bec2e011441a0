"""Observations for the per-tyre model: short-window averages of slip and normalised force.

Why windows: a one-hour 100 Hz drive has 360,000 samples, each with slip noise of the same size
as the slip itself. Averaging over ~0.25 s keeps the slow true slip (it follows the driver's
pedal) while dividing the white sensor noise variance by the window length, and it reduces the
data the sampler touches by the same factor. The remaining noise in *both* slip and force is
handled by the errors-in-variables likelihood of :mod:`tyrebayes.inference.tyre_model`.

Arrays are padded to a fixed bucket size with a mask so that new data of the same bucket reuse
the compiled model.
"""

from __future__ import annotations

from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from .._errors import BadInputError

SURFACES = ("dry", "wet", "snow", "ice")


class TyreObservations(eqx.Module):
    """Window-averaged observations of one tyre set (the driven axle), padded with a mask.

    Fields
    ------
    slip : Float[Array, "n"]
        Measured longitudinal slip σ_x of the driven axle [-] (window mean).
    rho : Float[Array, "n"]
        Measured normalised force ρ_x = F_x/F_z of the driven axle [-] (window mean).
    slip_sd, rho_sd : Float[Array, "n"]
        Standard deviation of the measurement noise of each window mean [-].
    temperature_c : Float[Array, "n"]
        Tyre temperature estimate for the window [°C].
    neighbour_slip : Float[Array, "n"]
        Mean measured slip of the adjacent windows [-]. Its noise is independent of this window's,
        while the true slip, which follows the pedals, is close to it: an instrument that locates
        the window's true slip without using its own noisy measurement.
    drive_index : Int[Array, "n"]
        Which drive (day) the window belongs to: 0 … n_drives − 1.
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
    neighbour_slip: Float[Array, "n"]
    drive_index: Int[Array, "n"]
    surface_index: Int[Array, "n"]
    mask: Bool[Array, "n"]
    n_drives: int = eqx.field(static=True)
    surfaces: tuple[str, ...] = eqx.field(static=True)

    @property
    def n_used(self) -> int:
        """Number of real (unpadded) windows."""
        return int(np.asarray(self.mask).sum())

    @property
    def n_surfaces(self) -> int:
        return len(self.surfaces)


def _bucket_size(n: int) -> int:
    """Smallest power of two ≥ n (≥ 64): data of similar size share one compiled model."""
    return max(64, 1 << max(0, int(np.ceil(np.log2(max(n, 1))))))


def window_means(
    values: np.ndarray, valid: np.ndarray, window: int
) -> tuple[np.ndarray, np.ndarray]:
    """Means of consecutive blocks of ``window`` samples and the number of valid samples in each."""
    n_blocks = len(values) // window
    v = np.where(valid, values, 0.0)[: n_blocks * window].reshape(n_blocks, window)
    counts = valid[: n_blocks * window].reshape(n_blocks, window).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        means = v.sum(axis=1) / counts
    return means, counts


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

    Returns
    -------
    dict
        ``slip``, ``rho``, ``slip_sd``, ``rho_sd``, ``temperature_c`` arrays, one entry per kept
        window, and ``neighbour_slip``. The noise sd of a window mean of k samples is sd/√k.
    """
    time_s = np.asarray(time_s, dtype=float)
    n = len(time_s)
    if n < 2:
        raise BadInputError(f"tyre observations: expected at least 2 samples, got {n}")
    dt = float(np.median(np.diff(time_s)))
    window = max(1, int(round(window_s / dt)))
    arrays = {
        "slip": np.asarray(slip, dtype=float),
        "rho": np.asarray(rho, dtype=float),
        "slip_sd": np.broadcast_to(np.asarray(slip_sd, dtype=float), (n,)),
        "rho_sd": np.broadcast_to(np.asarray(rho_sd, dtype=float), (n,)),
        "temperature_c": np.broadcast_to(np.asarray(temperature_c, dtype=float), (n,)),
    }
    for name, arr in arrays.items():
        if arr.shape != (n,):
            raise BadInputError(f"tyre observations: {name} expected shape ({n},), got {arr.shape}")
    valid = np.ones(n, dtype=bool) if usable is None else np.asarray(usable, dtype=bool).copy()
    for arr in arrays.values():
        valid &= np.isfinite(arr)
    out = {}
    counts = None
    for name, arr in arrays.items():
        means, counts = window_means(arr, valid, window)
        out[name] = means
    keep = counts >= max(1, int(np.ceil(min_fraction_valid * window)))
    out["neighbour_slip"] = _neighbour_mean(np.where(keep, out["slip"], np.nan))
    keep &= np.isfinite(out["neighbour_slip"])
    safe_counts = np.maximum(counts, 1)
    out = {k: v[keep] for k, v in out.items()}
    # Noise of a mean of k independent samples: sd/√k (the sd arrays were averaged above).
    out["slip_sd"] = out["slip_sd"] / np.sqrt(safe_counts[keep])
    out["rho_sd"] = out["rho_sd"] / np.sqrt(safe_counts[keep])
    return out


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
        Outputs of :func:`windowed_observations`, one per drive.
    surfaces : sequence of str
        Surface of each drive, from ``SURFACES``.
    pad_to : int, optional
        Padded length; default the next power of two.
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
    parts = {
        k: [] for k in ("slip", "rho", "slip_sd", "rho_sd", "temperature_c", "neighbour_slip")
    }
    drive_idx, surface_idx = [], []
    for d, (drive, surface) in enumerate(zip(drives, surfaces, strict=True)):
        m = len(drive["slip"])
        for k in parts:
            parts[k].append(np.asarray(drive[k], dtype=float))
        drive_idx.append(np.full(m, d))
        surface_idx.append(np.full(m, used_surfaces.index(surface)))
    n = sum(len(p) for p in parts["slip"])
    if n < 10:
        raise BadInputError(f"tyre observations: expected at least 10 usable windows, got {n}")
    size = pad_to or _bucket_size(n)
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
        neighbour_slip=jnp.asarray(pad(cat["neighbour_slip"], 0.0)),
        drive_index=jnp.asarray(pad(np.concatenate(drive_idx), 0)),
        surface_index=jnp.asarray(pad(np.concatenate(surface_idx), 0)),
        mask=jnp.asarray(np.arange(size) < n),
        n_drives=len(drives),
        surfaces=used_surfaces,
    )
