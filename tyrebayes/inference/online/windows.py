"""Windowed observations as the online estimator consumes them: one step's windows at a time.

A stream's windows (:func:`~tyrebayes.inference.tyre.data.observations_from_features`) are
grouped into the blocks of :data:`~tyrebayes.inference.tyre.data.BLOCK_S` seconds whose slips
share one offset in the per-tyre model, and consecutive blocks of one drive into steps. A step
holds whole blocks, so each block's offset is integrated out exactly within the step
(:func:`~tyrebayes.inference.tyre.model.block_offsets`), as in the batch likelihood, and the
filter's state carries nothing per block. Blocks without windows are skipped; the time between
the steps sets the process noise.

Why steps of several blocks: besides its windows' share (the block likelihood's Hessian and
gradients, which grow with the padded width) a step has a fixed cost (eigendecompositions of θ's
matrices, the Newton loop, the change tests), and the update is sequential Bayes either way:
only the linearisation points differ.

Steps are cut on a STEP_S clock by default: an update, and an alarm, at most STEP_S after its
windows. A step's cost grows with its padded width, windows or padding alike, and normal
driving fills a clock-cut step only partly (cruising, stops and turns give no slip windows),
so a replay of logged drives, where the alarms' latency matters less than the compute, can
pack sparse driving: with ``max_step_s`` above STEP_S a step takes further whole blocks after
its STEP_S while its windows fit the width and it spans at most ``max_step_s``
(:data:`PACKED_STEP_S`, ``tyrebayes online --max-step-s``; ``benchmarks/online_speed.py`` and
``benchmarks/online_change.py`` measure what it saves and what it costs the alarms). Either
way a drive's steps start at least STEP_S apart (at most 3600/STEP_S an hour, which the change
detector's false-alarm bound counts on, :mod:`.config`).

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
from ..tyre.data import BLOCK_S, SURFACES, TyreObservations, WindowTable

#: Length of a filter step on the clock [s], and the least time between two steps' starts:
#: whole blocks of BLOCK_S.
STEP_S = 30.0
#: Longest step when sparse driving is packed (module docstring): under 2.5 STEP_S, so that a
#: change alarm still needs two steps (:mod:`.change`).
PACKED_STEP_S = 60.0

# Fields of a block that are per window, with their padding value.
_WINDOW_FIELDS = {
    "slip": 0.0,
    "rho": 0.0,
    "slip_sd": 1.0,
    "rho_sd": 1.0,
    "temperature_c": 20.0,
    "load_change": 0.0,
    "rho_score": 0.0,
    "rho_score_slope": 0.0,
}


class WindowBlocks(eqx.Module):
    """Blocks of windows, padded to a common width, in time order.

    Attributes
    ----------
    slip, rho, slip_sd, rho_sd : Float[Array, "*b w"]
        As :class:`~tyrebayes.inference.tyre.data.TyreObservations` [-].
    temperature_c : Float[Array, "*b w"]
        Tyre temperature of each window [°C].
    load_change : Float[Array, "*b w"]
        The driven axle's ΔF_z/F_z,static in each window [-] (0 where not given).
    rho_score, rho_score_slope : Float[Array, "*b w"]
        Force-density score and its slope at each window's force (module docstring).
    at_limit : Bool[Array, "*b w"]
        ABS windows.
    block_index : Int[Array, "*b w"]
        Which of its step's blocks each window lies in, numbered 0 … in time order over the
        blocks that hold windows (so always below the width).
    mask : Bool[Array, "*b w"]
        False for padding.
    time_s : Float[Array, "*b"]
        End of each step [s]: STEP_S after its start or the end of its last block, whichever
        is later (drive time; the process noise grows with its differences).
    span_s : Float[Array, "*b"]
        From each step's start to its end [s] (0 for an empty step): the change detector caps
        a step's evidence per STEP_S it spans.
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
    load_change: Float[Array, "*b w"]
    rho_score: Float[Array, "*b w"]
    rho_score_slope: Float[Array, "*b w"]
    at_limit: Bool[Array, "*b w"]
    block_index: Int[Array, "*b w"]
    mask: Bool[Array, "*b w"]
    time_s: Float[Array, "*b"]
    span_s: Float[Array, "*b"]
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
            load_change=self.load_change,
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


def _pack_steps(
    drive: Int[np.ndarray, "k"],
    block: Int[np.ndarray, "k"],
    count: Int[np.ndarray, "k"],
    width: int,
    blocks_per_step: int,
    max_blocks_per_step: int,
) -> tuple[Int[np.ndarray, "k"], Int[np.ndarray, "s"]]:
    """The step of each of a stream's non-empty blocks (time order), numbered 0 …, and the
    block each step starts at (module docstring).

    A step starts at the ``blocks_per_step`` clock boundary at or before its first block, but
    not before the last step of the same drive ends, nor within ``blocks_per_step`` of its
    start. It takes every block up to ``blocks_per_step`` from its start, then more while
    they fit ``width`` windows and lie within ``max_blocks_per_step`` of it, and ends
    ``blocks_per_step`` after its start or with its last block, whichever is later. It never
    holds two drives. With ``max_blocks_per_step == blocks_per_step`` the steps are the
    clock's.
    """
    step = np.empty(block.size, dtype=np.int64)
    starts: list[int] = []
    fill, end = 0, 0
    for i in range(block.size):
        same_drive = i > 0 and drive[i] == drive[i - 1]
        span = block[i] - starts[-1] + 1 if starts else 0
        if same_drive and (
            span <= blocks_per_step or (fill + count[i] <= width and span <= max_blocks_per_step)
        ):
            fill += count[i]
        else:
            clock = block[i] // blocks_per_step * blocks_per_step
            start = max(clock, starts[-1] + blocks_per_step, end) if same_drive else clock
            starts.append(start)
            fill = count[i]
        end = max(block[i] + 1, starts[-1] + blocks_per_step)
        step[i] = len(starts) - 1
    return step, np.asarray(starts, dtype=np.int64)


def window_blocks(
    windows: WindowTable,
    surface: str = "dry",
    *,
    width: int | None = None,
    step_s: float = STEP_S,
    max_step_s: float | None = None,
    time_offset_s: float = 0.0,
) -> WindowBlocks:
    """Group one stream's windows into time-ordered steps for the online estimator.

    Parameters
    ----------
    windows : WindowTable
        :func:`~tyrebayes.inference.tyre.data.observations_from_features` output (``time_s``,
        ``slip``, ``rho``, the noise sds, ``temperature_c``; ``at_limit`` if given, else no
        ABS window; ``rho_score`` and ``rho_score_slope`` if given, else 0: no force-noise
        correction; ``load_change`` if given, else 0 (the static load); ``drive`` if given,
        a label per window that changes where a new drive begins, else one drive).
        Steps never straddle two drives.
    surface : str
        Road surface.
    width : int, optional
        Windows per step after padding; default the most that ``step_s`` of the stream holds.
        Streams padded to one width share one compiled filter.
    step_s : float
        Length of a clock step [s], a whole number of BLOCK_S blocks.
    max_step_s : float, optional
        Longest span of a step [s], a whole number of BLOCK_S blocks ≥ ``step_s``: a step
        takes further blocks up to this while their windows fit ``width`` (module docstring).
        Default ``step_s``: steps cut on the clock.
    time_offset_s : float
        Added to the windows' times (to join drives end to end).

    Raises
    ------
    BadInputError
        No windows, or ``step_s`` of the stream holding more than ``width`` windows.

    Examples
    --------
    >>> from tyrebayes import load_vehicle
    >>> from tyrebayes._resources import data_dir
    >>> from tyrebayes.inference.online import stream_windows
    >>> path = data_dir() / "comma2k19_rav4_segment.csv"
    >>> windows = stream_windows(path, load_vehicle("suv_rav4"))
    >>> blocks = window_blocks(windows)
    >>> blocks.slip.shape[0], int(blocks.mask.sum()) == windows.n_windows
    (2, True)
    """
    max_step_s = step_s if max_step_s is None else max_step_s
    blocks_per_step, max_blocks = _blocks_per_step(step_s, max_step_s)
    if surface not in SURFACES:
        raise BadInputError(f"surface: expected one of {SURFACES}, got {surface!r}")
    order = _finite_in_time_order(windows, time_offset_s)
    time = windows.time_s[order] + time_offset_s
    drive = np.zeros(order.size, np.int64) if windows.drive is None else windows.drive[order]
    steps = _StepLayout.of(time, drive, width, blocks_per_step, max_blocks)
    arrays = {}
    for name, fill in _WINDOW_FIELDS.items():
        values = getattr(windows, name)
        values = np.zeros(order.size) if values is None else values[order]
        arrays[name] = jnp.asarray(steps.grid(values, fill))
    limit = np.zeros(order.size, bool) if windows.at_limit is None else windows.at_limit[order]
    return WindowBlocks(
        **arrays,
        at_limit=jnp.asarray(steps.grid(limit, False)),
        block_index=jnp.asarray(steps.grid(steps.block_in_step, 0).astype(np.int32)),
        mask=jnp.asarray(steps.grid(np.ones(order.size, bool), False)),
        time_s=jnp.asarray(steps.end_block * BLOCK_S, dtype=float),
        span_s=jnp.asarray((steps.end_block - steps.start_block) * BLOCK_S, dtype=float),
        drive_start=jnp.asarray(np.concatenate([[True], np.diff(steps.step_drive) != 0])),
        surface=surface,
    )


def _blocks_per_step(step_s: float, max_step_s: float) -> tuple[float, float]:
    """BLOCK_S blocks in a clock step and in the longest step, each checked to be whole."""
    blocks_per_step = step_s / BLOCK_S
    max_blocks = max_step_s / BLOCK_S
    if not (blocks_per_step >= 1 and float(blocks_per_step).is_integer()):
        raise ValueError(f"step_s: expected a whole multiple of {BLOCK_S} s, got {step_s}")
    if not (max_blocks >= blocks_per_step and float(max_blocks).is_integer()):
        raise BadInputError(
            f"max_step_s: expected a whole multiple of {BLOCK_S} s ≥ step_s = {step_s}, "
            f"got {max_step_s}"
        )
    return blocks_per_step, max_blocks


def _finite_in_time_order(windows: WindowTable, time_offset_s: float) -> Int[np.ndarray, "k"]:
    """Positions of the windows whose numbers are all finite (the others carry nothing the
    likelihood can read), in time order (stable)."""
    time = windows.time_s + time_offset_s
    if time.size == 0:
        raise BadInputError("online estimator: expected at least one window, got none")
    finite = np.isfinite(time)
    for values in (
        windows.slip,
        windows.rho,
        windows.slip_sd,
        windows.rho_sd,
        windows.temperature_c,
    ):
        finite &= np.isfinite(values)
    if not finite.any():
        raise BadInputError("online estimator: expected at least one finite window, got none")
    return np.flatnonzero(finite)[np.argsort(time[finite], kind="stable")]


class _StepLayout(eqx.Module):
    """Where each of a stream's windows (time order) goes: its step and slot in the step, its
    block numbered within the step, and each step's start and end block and drive."""

    step: Int[np.ndarray, "k"]
    slot: Int[np.ndarray, "k"]
    block_in_step: Int[np.ndarray, "k"]
    start_block: Int[np.ndarray, "s"]
    end_block: Int[np.ndarray, "s"]
    step_drive: Int[np.ndarray, "s"]
    width: int = eqx.field(static=True)

    @classmethod
    def of(
        cls,
        time: Float[np.ndarray, "k"],
        drive: Int[np.ndarray, "k"],
        width: int | None,
        blocks_per_step: float,
        max_blocks: float,
    ) -> _StepLayout:
        """The layout of windows at ``time`` [s, sorted] of ``drive`` into steps of ``width``
        windows (default the most any ``blocks_per_step`` of the stream holds)."""
        block = np.floor(time / BLOCK_S).astype(np.int64)
        # One key per (drive, block), in time order: a drive boundary inside a block splits it.
        # Drives are spaced apart in the keys by more than a step's span.
        new_drive = np.concatenate([[True], drive[1:] != drive[:-1]])
        drive_number = np.cumsum(new_drive) - 1
        keys = drive_number * (int(block.max()) + 1 + int(max_blocks)) + block
        block_keys, first, window_key, block_counts = np.unique(
            keys, return_index=True, return_inverse=True, return_counts=True
        )
        if width is None:
            # The most windows that any step_s of the stream holds (the step's forced span).
            total = np.concatenate([[0], np.cumsum(block_counts)])
            ends = np.searchsorted(block_keys, block_keys + int(blocks_per_step))
            width = int(np.max(total[ends] - total[:-1]))
        width = int(width)
        step_of_block, start_block = _pack_steps(
            drive_number[first],
            block[first],
            block_counts,
            width,
            int(blocks_per_step),
            int(max_blocks),
        )
        step = step_of_block[window_key]
        counts = np.bincount(step)
        if counts.max() > width:
            raise BadInputError(
                f"online estimator: expected at most {width} windows per step, got {counts.max()}"
            )
        step_start = np.concatenate([[0], np.cumsum(counts)[:-1]])
        # Each window's block, numbered within its step over the blocks that hold windows.
        first_block_of_step = np.searchsorted(step_of_block, np.arange(counts.size))
        block_in_step = np.arange(block_counts.size) - first_block_of_step[step_of_block]
        last_block = block[first][np.r_[first_block_of_step[1:], block_counts.size] - 1]
        return cls(
            step=step,
            slot=np.arange(time.size) - step_start[step],
            block_in_step=block_in_step[window_key],
            start_block=start_block,
            # A step ends STEP_S after its start or with its last block, whichever is later.
            end_block=np.maximum(last_block + 1, start_block + int(blocks_per_step)),
            step_drive=drive_number[first][first_block_of_step],
            width=width,
        )

    def grid(self, values: np.ndarray, fill) -> np.ndarray:
        """Per-window ``values`` (time order) on the (step, slot) grid, ``fill`` elsewhere."""
        out = np.full((self.start_block.size, self.width), fill, dtype=values.dtype)
        out[self.step, self.slot] = values
        return out


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
        span_s=pad(blocks.span_s, 0.0),
        drive_start=pad(blocks.drive_start, False),
        surface=blocks.surface,
    )


__all__ = ["PACKED_STEP_S", "STEP_S", "WindowBlocks", "pad_steps", "window_blocks"]
