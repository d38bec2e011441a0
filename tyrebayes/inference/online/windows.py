"""Windowed observations as the online estimator consumes them: one step's windows at a time.

A stream's windows (:func:`~tyrebayes.inference.tyre.data.observations_from_features`) are
grouped into steps of :data:`STEP_S` seconds, and within a step into the blocks of
:data:`~tyrebayes.inference.tyre.data.BLOCK_S` seconds whose slips share one offset in the
per-tyre model. A step holds whole blocks, so each block's offset is integrated out exactly
within the step (:func:`~tyrebayes.inference.tyre.model.block_offsets`), as in the batch
likelihood, and the filter's state carries nothing per block. Steps without windows are
skipped; the time between the steps that remain sets the process noise.

Why steps of several blocks: a step's cost is mostly fixed (a Hessian of θ, a few Newton
iterations), hardly its windows' (they are vectorised), so a step per 30 s costs a sixth of a
step per 5 s block for the same answer (the update is sequential Bayes either way; only the
linearisation points differ).

The windows' force-density scores (``rho_score``, for E[ρ_true | ρ_obs]) are taken as the stream
pipeline gives them: estimated over the stream that the windows come from. In a car that is the
previous drive's or a running estimate; here it is a look-ahead of the force distribution only
(not of slip, nor of any parameter), stated in the command's and the benchmarks' output.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ..._errors import BadInputError
from ..tyre.data import BLOCK_S, SURFACES, TyreObservations

#: Length of one filter step [s]: whole blocks of BLOCK_S (module docstring).
STEP_S = 30.0

# Fields of a block that are per window, with their padding value.
_WINDOW_FIELDS = {
    "slip": 0.0,
    "rho": 0.0,
    "slip_sd": 1.0,
    "rho_sd": 1.0,
    "temperature_c": 20.0,
    "rho_score": 0.0,
    "rho_score_slope": 0.0,
}


class WindowBlocks(eqx.Module):
    """Blocks of windows, padded to a common width, in time order.

    Fields
    ------
    slip, rho, slip_sd, rho_sd : Float[Array, "*b w"]
        As :class:`~tyrebayes.inference.tyre.data.TyreObservations` [-].
    temperature_c : Float[Array, "*b w"]
        Tyre temperature of each window [°C].
    rho_score, rho_score_slope : Float[Array, "*b w"]
        Force-density score and its slope at each window's force (module docstring).
    at_limit : Bool[Array, "*b w"]
        ABS windows.
    block_index : Int[Array, "*b w"]
        Which BLOCK_S block of its step each window lies in (0 …).
    mask : Bool[Array, "*b w"]
        False for padding.
    time_s : Float[Array, "*b"]
        End of each block [s] (drive time; the process noise grows with its differences).
    drive_start : Bool[Array, "*b"]
        The first step of a drive: the per-drive nuisances (slip offset, force gain) start
        again from their prior there, as they are per drive in the batch model.
    surface : str
        Road surface of the stream (static).
    """

    slip: Float[Array, "*b w"]
    rho: Float[Array, "*b w"]
    slip_sd: Float[Array, "*b w"]
    rho_sd: Float[Array, "*b w"]
    temperature_c: Float[Array, "*b w"]
    rho_score: Float[Array, "*b w"]
    rho_score_slope: Float[Array, "*b w"]
    at_limit: Bool[Array, "*b w"]
    block_index: Int[Array, "*b w"]
    mask: Bool[Array, "*b w"]
    time_s: Float[Array, "*b"]
    drive_start: Bool[Array, "*b"]
    surface: str = eqx.field(static=True)

    def __check_init__(self):
        if self.surface not in SURFACES:
            raise ValueError(f"surface: expected one of {SURFACES}, got {self.surface!r}")

    @property
    def n_blocks(self) -> int:
        return int(self.time_s.shape[0]) if self.time_s.ndim else 1

    def observations(self, slip_weight: Float[Array, ""]) -> TyreObservations:
        """One block (unbatched) as the per-tyre model's observations, its slips weighted."""
        width = self.slip.shape[-1]
        zeros_int = jnp.zeros(width, dtype=jnp.int32)
        return TyreObservations(
            slip=self.slip,
            rho=self.rho,
            slip_sd=self.slip_sd,
            rho_sd=self.rho_sd,
            temperature_c=self.temperature_c,
            neighbour_slip=jnp.zeros_like(self.slip),
            slip_weight=jnp.broadcast_to(slip_weight, self.slip.shape).astype(self.slip.dtype),
            imu_gain_log_sd=jnp.zeros_like(self.slip),
            rho_score=self.rho_score,
            rho_score_slope=self.rho_score_slope,
            at_limit=self.at_limit,
            drive_index=zeros_int,
            block_index=self.block_index,
            surface_index=zeros_int,
            mask=self.mask,
            n_drives=1,
            surfaces=(self.surface,),
        )


def window_blocks(
    windows: dict[str, np.ndarray],
    surface: str = "dry",
    *,
    width: int | None = None,
    step_s: float = STEP_S,
    time_offset_s: float = 0.0,
) -> WindowBlocks:
    """Group one stream's windows into time-ordered steps for the online estimator.

    Parameters
    ----------
    windows : dict of ndarray
        :func:`~tyrebayes.inference.tyre.data.observations_from_features` output (``time_s``,
        ``slip``, ``rho``, the noise sds, ``temperature_c``, ``at_limit``; ``rho_score`` and
        ``rho_score_slope`` if present, else 0: no force-noise correction; ``drive`` if
        present, an integer per window that changes where a new drive begins, else one drive).
        Steps never straddle two drives.
    surface : str
        Road surface.
    width : int, optional
        Windows per step after padding; default the fullest step's count. Streams padded to
        one width share one compiled filter.
    step_s : float
        Step length [s], a whole number of BLOCK_S blocks.
    time_offset_s : float
        Added to the windows' times (to join drives end to end).

    Raises
    ------
    BadInputError
        No windows, or a step fuller than ``width``.
    """
    blocks_per_step = step_s / BLOCK_S
    if not (blocks_per_step >= 1 and float(blocks_per_step).is_integer()):
        raise ValueError(f"step_s: expected a whole multiple of {BLOCK_S} s, got {step_s}")
    if surface not in SURFACES:
        raise BadInputError(f"surface: expected one of {SURFACES}, got {surface!r}")
    time = np.asarray(windows["time_s"], dtype=float) + time_offset_s
    if time.size == 0 or "slip" not in windows:
        raise BadInputError("online estimator: expected at least one window, got none")
    # Windows whose numbers are not finite carry nothing the likelihood can read.
    finite = np.isfinite(time)
    for name in ("slip", "rho", "slip_sd", "rho_sd", "temperature_c"):
        finite &= np.isfinite(np.asarray(windows[name], dtype=float))
    if not finite.any():
        raise BadInputError("online estimator: expected at least one finite window, got none")
    order = np.flatnonzero(finite)[np.argsort(time[finite], kind="stable")]
    time = time[order]
    drive = np.asarray(windows.get("drive", np.zeros(len(finite))), dtype=np.int64)[order]
    block = np.floor(time / BLOCK_S).astype(np.int64)
    step = block // int(blocks_per_step)
    # One key per (drive, step), in time order: a drive boundary inside a step splits it.
    new_drive = np.concatenate([[True], drive[1:] != drive[:-1]])
    drive_number = np.cumsum(new_drive) - 1
    keys = drive_number * (int(step.max()) + 1) + step
    ids, first, inverse, counts = np.unique(
        keys, return_index=True, return_inverse=True, return_counts=True
    )
    step_of_key, drive_of_key = step[first], drive_number[first]
    width = int(counts.max()) if width is None else int(width)
    if counts.max() > width:
        raise BadInputError(
            f"online estimator: expected at most {width} windows per step, got {counts.max()}"
        )
    slot = np.arange(time.size) - np.concatenate([[0], np.cumsum(counts)[:-1]])[inverse]
    n = len(ids)
    arrays = {}
    for name, fill in _WINDOW_FIELDS.items():
        values = windows.get(name)
        values = np.zeros(time.size) if values is None else np.asarray(values, float)[order]
        grid = np.full((n, width), fill, dtype=float)
        grid[inverse, slot] = values
        arrays[name] = jnp.asarray(grid)
    at_limit = np.zeros((n, width), dtype=bool)
    limit = windows.get("at_limit")
    if limit is not None:
        at_limit[inverse, slot] = np.asarray(limit, dtype=bool)[order]
    mask = np.zeros((n, width), dtype=bool)
    mask[inverse, slot] = True
    block_index = np.zeros((n, width), dtype=np.int32)
    block_index[inverse, slot] = block - step * int(blocks_per_step)
    return WindowBlocks(
        **arrays,
        at_limit=jnp.asarray(at_limit),
        block_index=jnp.asarray(block_index),
        mask=jnp.asarray(mask),
        time_s=jnp.asarray((step_of_key + 1) * step_s, dtype=float),
        drive_start=jnp.asarray(np.concatenate([[True], np.diff(drive_of_key) != 0])),
        surface=surface,
    )


def pad_steps(blocks: WindowBlocks, n_steps: int) -> WindowBlocks:
    """``blocks`` followed by empty steps up to ``n_steps`` (at the last step's time).

    An empty step changes nothing (no windows, no time elapsed), so streams of different length
    padded to one number of steps share one compiled filter, and cars of different length can
    be vmapped together.
    """
    n = blocks.n_blocks
    if n_steps < n:
        raise ValueError(f"pad_steps: expected n_steps ≥ {n}, got {n_steps}")
    extra = n_steps - n

    def pad(x, fill):
        tail = jnp.full((extra, *x.shape[1:]), fill, dtype=x.dtype)
        return jnp.concatenate([x, tail])

    fields = {name: pad(getattr(blocks, name), fill) for name, fill in _WINDOW_FIELDS.items()}
    return WindowBlocks(
        **fields,
        at_limit=pad(blocks.at_limit, False),
        block_index=pad(blocks.block_index, 0),
        mask=pad(blocks.mask, False),
        time_s=pad(blocks.time_s, blocks.time_s[-1]),
        drive_start=pad(blocks.drive_start, False),
        surface=blocks.surface,
    )


__all__ = ["STEP_S", "WindowBlocks", "pad_steps", "window_blocks"]
