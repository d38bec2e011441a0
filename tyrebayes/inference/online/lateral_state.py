"""The online lateral estimator's state: the equations' moments and the Gaussian they give.

The data's part is the two equations' accumulated moments
(:class:`~.lateral_statistics.EquationMoments`), faded over :data:`~.lateral.MEMORY_S`: from
them the likelihood at any parameters is exact in the linear range, so every block re-weighs all
earlier data at the current estimate and the current VIFs, as the batch fit weighs all of its
samples at its own.
"""

from __future__ import annotations

import equinox as eqx
from jaxtyping import Array, Bool, Float

from .lateral_statistics import EquationMoments
from .lateral_vif import settled


class LateralState(eqx.Module):
    """The estimator's state after a block.

    Attributes
    ----------
    mean, cov : Array
        The posterior Gaussian (Laplace) over the unconstrained coordinates
        (:func:`~.lateral_sites.linear_sites`).
    steering, kinematic : EquationMoments
        The equations' moments so far, faded.
    batches_30s : Float[Array, "2"]
        30 s batches each equation has seen (not faded; readiness counts them).
    steering_vif, kinematic_vif : Float[Array, ""]
        The equations' VIFs at ``mean``.
    time_s : Float[Array, ""]
        Time of the last block's end [s].
    n_samples, n_skipped : Float[Array, ""]
        Samples that entered the steering equation; samples left out for |a_x|.
    converged : Bool[Array, ""]
        Whether the last block's Gauss-Newton steps ended below their tolerance (not at their
        limit, :data:`~.lateral.NEWTON_STEPS`).
    """

    mean: Float[Array, " p"]
    cov: Float[Array, "p p"]
    steering: EquationMoments
    kinematic: EquationMoments
    batches_30s: Float[Array, "2"]
    steering_vif: Float[Array, ""]
    kinematic_vif: Float[Array, ""]
    time_s: Float[Array, ""]
    n_samples: Float[Array, ""]
    n_skipped: Float[Array, ""]
    converged: Bool[Array, ""]

    def vif_settled(self) -> Bool[Array, ""]:
        """Whether both equations' VIFs have seen enough 30 s batches
        (:func:`~.lateral_vif.settled`)."""
        return settled(self.batches_30s)


__all__ = ["LateralState"]
