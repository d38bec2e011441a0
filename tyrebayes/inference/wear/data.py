"""Inputs of the wear model: priors, and the tyre sets collected into arrays (:class:`WearData`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import equinox as eqx
import numpy as np

from ..._domain import TYRE_TYPES
from ...physics.wear import DriveWork, TreadGeometry, WearObservations


@dataclasses.dataclass(frozen=True)
class WearPriors:
    """Prior scales of the wear model (units in the names).

    ``gamma_median_mm3_per_j`` 0.04 with log-sd 1.0 spans 0.007-0.2 mm^3/J at 90 % (Schallamach
    abrasabilities of tread compounds are O(0.01-0.1) mm^3/J; the ADAC masses imply ~0.03-0.08 for
    this package's duty profile). ``kappa_sd_per_k`` 0.03: a 10 K warmer tyre changes gamma by up
    to ~x1.8 at 2 sd (oxidative wear roughly doubles per 10-20 K, thesis Sec. 6.4 [29]).
    """

    gamma_median_mm3_per_j: float = 0.04
    gamma_log_sd: float = 1.0
    type_spread_log_sd: float = 0.3
    kappa_sd_per_k: float = 0.03
    initial_depth_mm: float = 8.0
    initial_depth_sd_mm: float = 0.5
    depth_noise_scale_mm: float = 0.3
    radius_noise_scale: float = 1e-3
    radius_offset_sd: float = 3e-3


@dataclasses.dataclass(frozen=True)
class WearData:
    """Everything the wear model needs, padded to equal drive counts per set (numpy arrays).

    Build with :func:`build_wear_data`. ``kernel[s, d, a, b]`` (zeros for padded drives),
    ``grid_c[b]``, ``set_type[s]``, ``c_xr_log_mean[s]``/``c_xr_log_sd[s]``; depth readings
    ``depth_set/depth_drive/depth_axle/depth_mm``; radius drift ``drift[s, d]`` with
    ``drift_mask[s, d]``.
    """

    kernel: np.ndarray
    grid_c: np.ndarray
    set_type: np.ndarray
    type_names: tuple[str, ...]
    c_xr_log_mean: np.ndarray
    c_xr_log_sd: np.ndarray
    depth_set: np.ndarray
    depth_drive: np.ndarray
    depth_axle: np.ndarray
    depth_mm: np.ndarray
    drift: np.ndarray
    drift_mask: np.ndarray
    wear_area_mm2: float
    radius_per_depth_over_r0: float

    @property
    def n_sets(self) -> int:
        return int(self.kernel.shape[0])

    @property
    def n_types(self) -> int:
        return len(self.type_names)


def c_xr_lognormal(c_xr) -> tuple[float, float]:
    """(log-mean, log-sd) of C_xr from posterior draws (array) or a ``(mean, sd)`` pair."""
    if isinstance(c_xr, tuple | list) and len(c_xr) == 2:
        mean, sd = float(c_xr[0]), float(c_xr[1])
        if not (mean > 0 and sd >= 0):
            raise ValueError(f"c_xr: expected (mean > 0, sd >= 0), got {c_xr!r}")
        log_sd = float(np.sqrt(np.log1p((sd / mean) ** 2)))
        return float(np.log(mean) - 0.5 * log_sd**2), max(log_sd, 1e-6)
    draws = np.asarray(c_xr, dtype=float).ravel()
    if draws.size < 2 or not np.all(draws > 0):
        raise ValueError(f"c_xr: expected >= 2 positive posterior draws, got {draws.size} values")
    logs = np.log(draws)
    return float(logs.mean()), max(float(logs.std(ddof=1)), 1e-6)


class WearSet(eqx.Module):
    """One tyre set's wear inputs: its drives' friction work, its observations, its stiffness.

    Attributes
    ----------
    work : DriveWork
        Per drive and axle, the friction-work kernel binned by tyre temperature [J].
    observations : WearObservations
        Tread-depth readings [mm] and per-drive rolling-radius drift [-].
    tyre_type : str
        One of :data:`tyrebayes._domain.TYRE_TYPES` (or a name given in ``type_names``).
    c_xr_log_mean, c_xr_log_sd : float
        Log-normal summary of the set's compensated stiffness C_xr [-] (from the per-tyre
        posterior): build with :meth:`from_c_xr`.
    """

    work: DriveWork
    observations: WearObservations
    tyre_type: str = eqx.field(static=True)
    c_xr_log_mean: float
    c_xr_log_sd: float

    def __check_init__(self):
        if not self.c_xr_log_sd > 0:
            raise ValueError(f"c_xr_log_sd: expected > 0, got {self.c_xr_log_sd}")

    @classmethod
    def from_c_xr(
        cls, work: DriveWork, observations: WearObservations, tyre_type: str, c_xr
    ) -> WearSet:
        """A set whose C_xr is posterior draws (array) or a ``(mean, sd)`` pair."""
        log_mean, log_sd = c_xr_lognormal(c_xr)
        return cls(work, observations, tyre_type, log_mean, log_sd)


def build_wear_data(
    sets: Sequence[WearSet],
    use_depth: bool = True,
    use_drift: bool = True,
    geom: TreadGeometry | None = None,
    type_names: tuple[str, ...] | None = None,
) -> WearData:
    """Collect tyre sets into :class:`WearData`, padded to equal drive counts.

    ``use_depth`` / ``use_drift`` select the observation sources (at least one); ``type_names``
    fixes the order of the type-level parameters (default: the package's order of the types
    present).

    Examples
    --------
    Two sets of three and two drives (two temperature bins), the shorter padded:

    >>> import jax.numpy as jnp
    >>> from tyrebayes.physics.wear import DriveWork, WearObservations
    >>> def tyre_set(n, tyre_type):
    ...     work = DriveWork(jnp.full(n, 20.0), jnp.full(n, 10.0), jnp.full((n, 2, 2), 1e6),
    ...                      jnp.array([10.0, 30.0]), jnp.zeros((n, 2)), jnp.full((n, 2), 20.0))
    ...     obs = WearObservations(jnp.array([0, n]), jnp.array([0, 0]), jnp.array([8.0, 7.9]),
    ...                            jnp.zeros(n), depth_noise_mm=0.1, radius_noise=1e-4)
    ...     return WearSet.from_c_xr(work, obs, tyre_type, (35.0, 1.5))
    >>> data = build_wear_data([tyre_set(3, "summer"), tyre_set(2, "winter")])
    >>> data.kernel.shape, data.type_names, data.drift_mask.sum(axis=1).tolist()
    ((2, 3, 2, 2), ('winter', 'summer'), [3, 2])
    """
    if not (use_depth or use_drift):
        raise ValueError("build_wear_data: expected use_depth or use_drift, got neither")
    if not sets:
        raise ValueError("build_wear_data: expected at least one tyre set, got none")
    geom = TreadGeometry() if geom is None else geom
    bad = [type(s).__name__ for s in sets if not isinstance(s, WearSet)]
    if bad:
        raise ValueError(f"build_wear_data: expected WearSet items, got {bad[0]}")
    present = [s.tyre_type for s in sets]
    if type_names is None:
        type_names = tuple(t for t in TYRE_TYPES if t in present) + tuple(
            sorted({t for t in present if t not in TYRE_TYPES})
        )
    unknown = sorted(set(present) - set(type_names))
    if unknown:
        raise ValueError(f"build_wear_data: tyre_type not in {type_names}, got {unknown}")
    n_drives = max(int(s.work.kernel_binned.shape[0]) for s in sets)
    grid = np.asarray(sets[0].work.grid_c)
    kernels = np.zeros((len(sets), n_drives, 2, grid.size))
    drift = np.zeros((len(sets), n_drives))
    mask = np.zeros((len(sets), n_drives), dtype=bool)
    d_set, d_drive, d_axle, d_val = [], [], [], []
    log_mean, log_sd = [], []
    for i, wear_set in enumerate(sets):
        work, obs = wear_set.work, wear_set.observations
        k = np.asarray(work.kernel_binned)
        kernels[i, : k.shape[0]] = k
        if use_drift:
            r = np.asarray(obs.radius_drift)
            drift[i, : r.size] = r
            mask[i, : r.size] = True
        if use_depth:
            n = np.asarray(obs.depth_mm).size
            d_set.append(np.full(n, i))
            d_drive.append(np.asarray(obs.depth_drive_index))
            d_axle.append(np.asarray(obs.depth_axle))
            d_val.append(np.asarray(obs.depth_mm))
        log_mean.append(wear_set.c_xr_log_mean)
        log_sd.append(wear_set.c_xr_log_sd)
    # keep only the temperature bins any drive reached: fewer flops per NUTS step
    used = np.nonzero(kernels.sum(axis=(0, 1, 2)) > 0)[0]
    lo, hi = (used.min(), used.max() + 1) if used.size else (0, grid.size)
    cat = (
        (lambda xs, dt: np.concatenate(xs).astype(dt))
        if use_depth
        else (lambda xs, dt: np.zeros(0, dtype=dt))
    )
    return WearData(
        kernel=kernels[..., lo:hi],
        grid_c=grid[lo:hi],
        set_type=np.array([type_names.index(t) for t in present]),
        type_names=tuple(type_names),
        c_xr_log_mean=np.array(log_mean),
        c_xr_log_sd=np.array(log_sd),
        depth_set=cat(d_set, int),
        depth_drive=cat(d_drive, int),
        depth_axle=cat(d_axle, int),
        depth_mm=cat(d_val, float),
        drift=drift,
        drift_mask=mask,
        wear_area_mm2=float(geom.wear_area_mm2),
        radius_per_depth_over_r0=float(geom.radius_per_depth / geom.outer_radius_mm),
    )
