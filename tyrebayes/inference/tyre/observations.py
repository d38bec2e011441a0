"""The per-tyre model's observations: several drives' windows stacked and padded.

Arrays are padded to a fixed bucket size with a mask so that new data of the same bucket reuse
the compiled model (:func:`bucket_size`). Re-exported by :mod:`tyrebayes.inference.tyre.data`.
"""

from __future__ import annotations

from collections.abc import Sequence

import equinox as eqx
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ..._domain import SURFACES
from ..._errors import BadInputError
from ...internal.device_arrays import device_array
from .window_table import WindowTable
from .windows import _slip_window_scores

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

    Examples
    --------
    >>> from tyrebayes.inference.tyre.windows import windowed_observations
    >>> t = np.arange(0.0, 30.0, 0.01)
    >>> windows = windowed_observations(t, np.full(t.size, 0.003), np.full(t.size, 0.1), 1e-3, 0.01)
    >>> obs = stack_drives([windows], ["dry"], pad_to=128)
    >>> obs.surfaces, obs.slip.shape, int(obs.mask.sum())
    (('dry',), (128,), 120)
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


def stack_drives(
    drives: Sequence[WindowTable],
    surfaces: Sequence[str],
    *,
    pad_to: int | None = None,
) -> TyreObservations:
    """Combine the windows of several drives of one tyre set into padded observations.

    Parameters
    ----------
    drives : sequence of WindowTable
        Outputs of :func:`windowed_observations` or :func:`observations_from_features`, one per
        drive, with ``neighbour_slip``. Their ``rho_score`` and ``rho_score_slope`` are used if
        present, else computed from the drive's slip windows (:func:`force_density_score`);
        ``at_limit``, ``load_change`` and ``imu_gain_log_sd`` default to no ABS window, the
        static load and 0. Windows are kept in the order given (time order: the slip-weight
        estimate reads neighbours in the array).
    surfaces : sequence of str
        Surface of each drive, from ``SURFACES``.
    pad_to : int, optional
        Padded length; default :func:`bucket_size` (8 sizes per octave).

    Returns
    -------
    TyreObservations

    Examples
    --------
    Two drives of a linear tyre's windows (:func:`windowed_observations`), one per surface:

    >>> from tyrebayes.inference.tyre.windows import windowed_observations
    >>> t = np.arange(0.0, 60.0, 0.01)
    >>> rho = 0.1 + 0.05 * np.sin(t)
    >>> slip = rho / 30.0 + np.random.default_rng(0).normal(0.0, 1e-3, t.size)
    >>> windows = windowed_observations(t, slip, rho, slip_sd=1e-3, rho_sd=0.01)
    >>> obs = stack_drives([windows, windows], ["dry", "wet"])
    >>> obs.n_drives, obs.slip.shape, int(obs.mask.sum())
    (2, (480,), 480)
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
    parts, drive_idx, surface_idx, block_idx = _drive_parts(drives, surfaces, used_surfaces)
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
        slip=device_array(pad(cat["slip"], 0.0)),
        rho=device_array(pad(cat["rho"], 0.0)),
        slip_sd=device_array(pad(cat["slip_sd"], 1.0)),
        rho_sd=device_array(pad(cat["rho_sd"], 1.0)),
        temperature_c=device_array(pad(cat["temperature_c"], 20.0)),
        load_change=device_array(pad(cat["load_change"], 0.0)),
        neighbour_slip=device_array(pad(cat["neighbour_slip"], 0.0)),
        slip_weight=device_array(np.ones(size)),
        imu_gain_log_sd=device_array(pad(cat["imu_gain_log_sd"], 0.0)),
        rho_score=device_array(pad(cat["rho_score"], 0.0)),
        rho_score_slope=device_array(pad(cat["rho_score_slope"], 0.0)),
        at_limit=device_array(pad(cat["at_limit"], False)),
        drive_index=device_array(pad(np.concatenate(drive_idx), 0)),
        block_index=device_array(pad(np.concatenate(block_idx), 0)),
        surface_index=device_array(pad(np.concatenate(surface_idx), 0)),
        mask=device_array(np.arange(size) < n),
        n_drives=len(drives),
        surfaces=used_surfaces,
    )


def _drive_parts(drives, surfaces, used_surfaces):
    """Each drive's window arrays (filled in where a hand-made drive leaves them out), and its
    windows' drive, surface and block indices: ``(parts, drive_idx, surface_idx, block_idx)``,
    lists with one entry per drive."""
    parts = {k: [] for k in _COLUMN_FILLS}
    drive_idx, surface_idx, block_idx = [], [], []
    n_blocks = 0
    for d, (drive, surface) in enumerate(zip(drives, surfaces, strict=True)):
        if not isinstance(drive, WindowTable):
            raise BadInputError(
                f"tyre observations: drive {d} expected a WindowTable "
                f"(WindowTable.from_dict converts a dict), got {type(drive).__name__}"
            )
        if drive.neighbour_slip is None:
            raise BadInputError(
                f"tyre observations: drive {d} expected a neighbour_slip column, got None"
            )
        m = len(drive)
        blocks = np.unique(np.floor(drive.time_s / BLOCK_S).astype(np.int64), return_inverse=True)[
            1
        ]
        block_idx.append(n_blocks + blocks.reshape(-1))
        n_blocks += int(blocks.max()) + 1 if m else 0
        for k, fill in _COLUMN_FILLS.items():
            values = getattr(drive, k)
            parts[k].append(np.full(m, fill) if values is None else values)
        if drive.rho_score is None:
            parts["rho_score"][-1], parts["rho_score_slope"][-1] = _slip_window_scores(
                drive.rho, drive.rho_sd, parts["at_limit"][-1]
            )
        drive_idx.append(np.full(m, d))
        surface_idx.append(np.full(m, used_surfaces.index(surface)))
    return parts, drive_idx, surface_idx, block_idx


#: The per-window arrays :func:`stack_drives` takes from each drive, with what fills those that
#: hand-made drives may leave out: no ABS windows, no IMU rescaling, the static load (the
#: force-density scores are computed from the drive's slip windows instead).
_COLUMN_FILLS = {
    "slip": None,
    "rho": None,
    "slip_sd": None,
    "rho_sd": None,
    "temperature_c": None,
    "load_change": 0.0,
    "neighbour_slip": None,
    "at_limit": False,
    "imu_gain_log_sd": 0.0,
    "rho_score": 0.0,
    "rho_score_slope": 0.0,
}
