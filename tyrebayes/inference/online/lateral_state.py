"""The online lateral estimator's state: the data's Gaussian messages and the window's samples.

The last blocks (:data:`~.lateral.WINDOW_BLOCKS`, 5 minutes) keep their samples
(:class:`Window`): their exact likelihood is taken at every step. Older blocks are kept as
Gaussian messages per likelihood part, re-weighted by the VIFs as they stand at every step
(:class:`LateralState`).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from ..lateral.data import CorneringObservations
from .lateral_vif import ResidualMoments


class Window(eqx.Module):
    """The samples of the last blocks (oldest first); empty rows fully masked.

    Attributes
    ----------
    speed, yaw_rate, yaw_acceleration, ay, steering : Float[Array, "w width"]
    mask, mask_kinematic : Bool[Array, "w width"]
    """

    speed: Float[Array, "w width"]
    yaw_rate: Float[Array, "w width"]
    yaw_acceleration: Float[Array, "w width"]
    ay: Float[Array, "w width"]
    steering: Float[Array, "w width"]
    mask: Bool[Array, "w width"]
    mask_kinematic: Bool[Array, "w width"]

    @classmethod
    def empty(cls, blocks: int, width: int, dtype) -> Window:
        zeros = jnp.zeros((blocks, width), dtype)
        false = jnp.zeros((blocks, width), bool)
        return cls(zeros + 10.0, zeros, zeros, zeros, zeros, false, false)

    def pushed(self, obs: CorneringObservations) -> Window:
        """The window with ``obs`` appended and the oldest block dropped."""

        def push(rows, new):
            return jnp.concatenate([rows[1:], new[None]], axis=0)

        return Window(
            *(
                push(getattr(self, f), getattr(obs, f))
                for f in (
                    "speed",
                    "yaw_rate",
                    "yaw_acceleration",
                    "ay",
                    "steering",
                    "mask",
                    "mask_kinematic",
                )
            )
        )

    def block(self, i, like: CorneringObservations) -> CorneringObservations:
        """Row ``i`` as observations, with ``like``'s constants."""
        return eqx.tree_at(
            lambda o: (
                o.speed,
                o.yaw_rate,
                o.yaw_acceleration,
                o.ay,
                o.steering,
                o.mask,
                o.mask_kinematic,
            ),
            like,
            (
                self.speed[i],
                self.yaw_rate[i],
                self.yaw_acceleration[i],
                self.ay[i],
                self.steering[i],
                self.mask[i],
                self.mask_kinematic[i],
            ),
        )


class LateralState(eqx.Module):
    """The estimator's state after a block.

    The data's part is kept as Gaussian messages per likelihood part (steering equation,
    kinematic equation, peak bound), unweighted: each block adds its Fisher information J at
    its mode θ* and J θ* + ∇ℓ(θ*). The posterior is the prior times the messages, the
    equations' weighted by 1/VIF as estimated *now*: a VIF that grows as slower correlations
    show (30 s and 60 s batches need minutes of data) re-weights every earlier block, as the
    batch fit's one VIF weights all of its samples.

    Attributes
    ----------
    mean, cov : Array
        The posterior Gaussian over the unconstrained coordinates.
    information : Float[Array, "3 p p"]
        Σ of the blocks' J, per part.
    shift : Float[Array, "3 p"]
        Σ of the blocks' J θ* + ∇ℓ(θ*), per part.
    time_s : Float[Array, ""]
        Time of the last block's end [s].
    steering, kinematic : ResidualMoments
        The two equations' residual sums (their VIFs).
    n_samples, n_skipped : Float[Array, ""]
        Samples that entered the steering equation; samples left out for |a_x|.
    window : Window
        The last :data:`~.lateral.WINDOW_BLOCKS` blocks' samples, whose likelihood is kept
        exact (their messages are not in ``information``/``shift``).
    """

    mean: Float[Array, " p"]
    cov: Float[Array, "p p"]
    information: Float[Array, "3 p p"]
    shift: Float[Array, "3 p"]
    window: Window
    time_s: Float[Array, ""]
    steering: ResidualMoments
    kinematic: ResidualMoments
    n_samples: Float[Array, ""]
    n_skipped: Float[Array, ""]

    def vif_settled(self) -> Bool[Array, ""]:
        """Whether both equations' VIFs have seen enough 30 s batches
        (:meth:`~.lateral_vif.ResidualMoments.settled`)."""
        return self.steering.settled() & self.kinematic.settled()


__all__ = ["LateralState", "Window"]
