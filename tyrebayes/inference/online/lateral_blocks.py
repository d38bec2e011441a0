"""A drive's cornering observations cut into the online lateral estimator's blocks.

The lateral estimator (:mod:`.lateral`) reads the batch fit's own observations
(:func:`~tyrebayes.inference.lateral.cornering_observations`: 2 Hz low-pass, 10 Hz, samples
braking or accelerating harder than
:data:`~tyrebayes.inference.lateral.data.MAX_LONGITUDINAL_MPS2` left out) in blocks of
:data:`LATERAL_STEP_S` on the clock, as a car would collect them. Besides those, the first and
last two samples of a block are left out of the kinematic equation: it differentiates V_x α_r
with a five-point stencil, which cannot reach across a block's edge.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from ...internal.device_arrays import device_array
from ..lateral.data import CorneringObservations

#: Length of one update of the lateral estimator on the clock [s] (the longitudinal one's).
LATERAL_STEP_S = 30.0


class LateralBlocks(eqx.Module):
    """Cornering observations in blocks: a leading block axis, ``width`` samples each.

    Attributes
    ----------
    speed, yaw_rate, yaw_acceleration, ay, steering : Float[Array, "blocks width"]
        As :class:`~tyrebayes.inference.lateral.CorneringObservations` (padding: speed 10 m/s,
        zeros, masked).
    ax : Float[Array, "blocks width"]
        The observations' a_x [m/s²] (padding: zeros).
    mask, mask_kinematic : Bool[Array, "blocks width"]
        The samples each equation reads: the batch masks, less (kinematic) the block's edges.
    n_skipped : Float[Array, " blocks"]
        Samples of each block left out for |a_x| (the observations' ``longitudinal``).
    time_s : Float[Array, " blocks"]
        Time at the end of each block since the record's start [s].
    dt_s : Array
        Sample interval [s] (0-d, as :class:`~tyrebayes.inference.lateral.CorneringObservations`'s).
    road_wheel : bool
        Whether ``steering`` is a road-wheel angle.
    mass_kg, wheelbase_m, cog_to_front_axle_m, yaw_inertia_kgm2, steering_ratio : Array
        The vehicle's constants (as the batch observations carry them).
    """

    speed: Float[Array, "blocks width"]
    yaw_rate: Float[Array, "blocks width"]
    yaw_acceleration: Float[Array, "blocks width"]
    ay: Float[Array, "blocks width"]
    steering: Float[Array, "blocks width"]
    ax: Float[Array, "blocks width"]
    mask: Bool[Array, "blocks width"]
    mask_kinematic: Bool[Array, "blocks width"]
    n_skipped: Float[Array, " blocks"]
    time_s: Float[Array, " blocks"]
    dt_s: Float[Array, ""] = eqx.field(converter=jnp.asarray)
    road_wheel: bool = eqx.field(static=True)
    mass_kg: Float[Array, ""]
    wheelbase_m: Float[Array, ""]
    cog_to_front_axle_m: Float[Array, ""]
    yaw_inertia_kgm2: Float[Array, ""]
    steering_ratio: Float[Array, ""]

    def __check_init__(self):
        shape = self.speed.shape
        if len(shape) != 2:
            raise ValueError(f"LateralBlocks.speed: expected (blocks, width), got shape {shape}")
        for name in ("yaw_rate", "yaw_acceleration", "ay", "steering", "ax", "mask"):
            if getattr(self, name).shape != shape:
                raise ValueError(
                    f"LateralBlocks.{name}: expected shape {shape}, got {getattr(self, name).shape}"
                )

    @property
    def n_blocks(self) -> int:
        return int(self.speed.shape[0])

    def part(self, start: int, count: int) -> LateralBlocks:
        """Blocks ``start`` to ``start + count``, padded after the record's end with empty
        blocks that end where the record does (no time passes in them).

        Cut in NumPy, and left there: an eager JAX operation is a small compiled program of
        its own, which a fleet worker that dropped its compiled programs would compile again for
        every drive, and the stored program that runs the part reads NumPy arrays
        (:func:`~tyrebayes.internal.stored_program.stored_program`).
        """
        end = min(start + count, self.n_blocks)
        pad = count - (end - start)
        times = np.asarray(self.time_s)
        fills = {"speed": 10.0, "time_s": float(times[end - 1 if end > start else -1])}

        def cut(name):
            x = np.asarray(getattr(self, name))[start:end]
            if pad:
                fill = np.full((pad, *x.shape[1:]), fills.get(name, 0), x.dtype)
                x = np.concatenate([x, fill])
            return x

        names = ("speed", "yaw_rate", "yaw_acceleration", "ay", "steering", "ax", "mask",
                 "mask_kinematic", "n_skipped", "time_s")  # fmt: skip
        return eqx.tree_at(lambda b: [getattr(b, n) for n in names], self, [cut(n) for n in names])

    def block(self, i) -> CorneringObservations:
        """Block ``i`` as the batch model's observations (traceable ``i``)."""
        return CorneringObservations(
            speed=self.speed[i],
            yaw_rate=self.yaw_rate[i],
            yaw_acceleration=self.yaw_acceleration[i],
            ay=self.ay[i],
            steering=self.steering[i],
            mask=self.mask[i],
            mask_kinematic=self.mask_kinematic[i],
            longitudinal=jnp.zeros_like(self.mask[i]),
            ax=self.ax[i],
            dt_s=self.dt_s,
            road_wheel=self.road_wheel,
            mass_kg=self.mass_kg,
            wheelbase_m=self.wheelbase_m,
            cog_to_front_axle_m=self.cog_to_front_axle_m,
            yaw_inertia_kgm2=self.yaw_inertia_kgm2,
            steering_ratio=self.steering_ratio,
            cornering_seconds=jnp.zeros((), self.speed.dtype),
        )


def lateral_blocks(
    obs: CorneringObservations,
    *,
    step_s: float = LATERAL_STEP_S,
    n_blocks: int | None = None,
) -> LateralBlocks:
    """Cut a drive's cornering observations into blocks of ``step_s`` (module docstring).

    Parameters
    ----------
    obs : CorneringObservations
        From :func:`~tyrebayes.inference.lateral.cornering_observations`.
    step_s : float
        Block length [s]; a whole number of samples (within 1 %).
    n_blocks : int, optional
        Pad (with empty blocks, which end where the record does) or cut to this many blocks:
        streams of different lengths then share one compiled run. Default: as many as the
        record fills.

    Returns
    -------
    LateralBlocks

    Examples
    --------
    >>> import numpy as np, jax.numpy as jnp
    >>> from tyrebayes.inference.lateral import CorneringObservations
    >>> n = 700
    >>> obs = CorneringObservations(
    ...     speed=jnp.full(n, 20.0), yaw_rate=jnp.zeros(n), yaw_acceleration=jnp.zeros(n),
    ...     ay=jnp.zeros(n), steering=jnp.zeros(n), mask=jnp.ones(n, bool),
    ...     mask_kinematic=jnp.ones(n, bool), longitudinal=jnp.zeros(n, bool),
    ...     ax=jnp.zeros(n), dt_s=0.1,
    ...     road_wheel=False,
    ...     mass_kg=jnp.asarray(1500.0), wheelbase_m=jnp.asarray(2.7),
    ...     cog_to_front_axle_m=jnp.asarray(1.1), yaw_inertia_kgm2=jnp.asarray(2500.0),
    ...     steering_ratio=jnp.asarray(15.0), cornering_seconds=jnp.asarray(0.0))
    >>> blocks = lateral_blocks(obs)
    >>> blocks.speed.shape, [float(t) for t in blocks.time_s]
    ((3, 300), [30.0, 60.0, 90.0])
    """
    dt = float(obs.dt_s)
    width = int(round(step_s / dt))
    # The decimated rate is the stream's median rate over the decimation step: within a
    # fraction of a per cent of 10 Hz on a real clock, so a block is the nearest whole number.
    if width < 10 or abs(width * dt - step_s) > 0.01 * step_s:
        raise ValueError(f"step_s: expected a whole number (≥ 10) of {dt} s samples, got {step_s}")
    n = int(obs.speed.shape[0])
    filled = max(1, -(-n // width))
    count = filled if n_blocks is None else int(n_blocks)
    total = count * width
    speed = np.asarray(obs.speed, float)
    mask = np.asarray(obs.mask)
    kinematic = np.asarray(obs.mask_kinematic)

    def padded(x, fill):
        x = np.asarray(x)[:total]
        out = np.full(total, fill, dtype=x.dtype)
        out[: x.size] = x
        return out.reshape(count, width)

    kinematic = padded(kinematic, False)
    # The five-point derivative of V_x α_r within a block does not reach its neighbours.
    kinematic[:, :2] = kinematic[:, -2:] = False
    dtype = obs.ay.dtype

    def arr(x, fill=0.0):
        return device_array(padded(np.asarray(x, float), fill), dtype=dtype)

    return LateralBlocks(
        speed=arr(speed, 10.0),
        yaw_rate=arr(obs.yaw_rate),
        yaw_acceleration=arr(obs.yaw_acceleration),
        ay=arr(obs.ay),
        steering=arr(obs.steering),
        ax=arr(obs.ax),
        mask=device_array(padded(mask, False)),
        mask_kinematic=device_array(kinematic),
        n_skipped=device_array(padded(np.asarray(obs.longitudinal), False).sum(axis=1), dtype),
        # Padding blocks end where the record does: no time passes in them, nothing fades.
        time_s=device_array(np.minimum(np.arange(1, count + 1), filled) * width * dt, dtype),
        dt_s=obs.dt_s,
        road_wheel=obs.road_wheel,
        mass_kg=obs.mass_kg,
        wheelbase_m=obs.wheelbase_m,
        cog_to_front_axle_m=obs.cog_to_front_axle_m,
        yaw_inertia_kgm2=obs.yaw_inertia_kgm2,
        steering_ratio=obs.steering_ratio,
    )


__all__ = ["LATERAL_STEP_S", "LateralBlocks", "lateral_blocks"]
