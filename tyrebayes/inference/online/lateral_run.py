"""What a run of the online lateral estimator over a drive gives: its estimate and trajectory."""

from __future__ import annotations

import equinox as eqx

from .lateral_summary import LateralTrajectory, OnlineLateral


class LateralRun(eqx.Module):
    """The online lateral estimate after a drive's last block, and each block's c_y moments.

    Returned by :func:`~.lateral.online_lateral`.

    Attributes
    ----------
    estimate : OnlineLateral
        The estimate after the last block, with its readiness (:attr:`OnlineLateral.k_identified`,
        :attr:`OnlineLateral.split_identified`).
    trajectory : LateralTrajectory
        Each block's c_y moments (log space), with the time at each block's end [s].

    Examples
    --------
    The estimator's prior, before any block: nothing is reported yet, and the reason says why.

    >>> import jax.numpy as jnp
    >>> from tyrebayes.inference.online.lateral import OnlineLateralEstimator
    >>> estimator = OnlineLateralEstimator.create()
    >>> state = estimator.init()
    >>> trajectory = LateralTrajectory(
    ...     time_s=state.time_s[None],
    ...     log_c_y_mean=state.mean[None, :2],
    ...     log_c_y_cov=state.cov[None, :2, :2],
    ...     vif_settled=jnp.zeros(1, bool),
    ... )
    >>> run = LateralRun(estimate=estimator.result(state), trajectory=trajectory)
    >>> out = run.to_dict()
    >>> out["lateral"], out["lateral_reason"][:18]
    (None, 'lateral: not yet: ')
    """

    estimate: OnlineLateral
    trajectory: LateralTrajectory

    def to_dict(self, seed: int = 0) -> dict:
        """The lateral part of ``tyrebayes online --json``: ``"lateral_reason"`` ("" once the
        understeer gradient is identified) and ``"lateral"`` (:meth:`OnlineLateral.to_dict`,
        null until then); ``seed`` draws the summaries' samples."""
        if not self.estimate.k_identified:
            return {"lateral_reason": self.estimate.reason(), "lateral": None}
        return {"lateral_reason": "", "lateral": self.estimate.to_dict(seed)}


__all__ = ["LateralRun"]
