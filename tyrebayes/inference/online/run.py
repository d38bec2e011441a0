"""What a run of the online estimator over a stream gives: its last state and every step."""

from __future__ import annotations

import equinox as eqx
import numpy as np

from .state import FilterState
from .summary import OnlineSummary


class OnlineRun(eqx.Module):
    """The filter state after a stream's last step, and the estimate at every step.

    Returned by :func:`~.estimator.online_estimate`, :func:`~.estimator.run_online` and
    :meth:`~.estimator.OnlineEstimator.run`; :func:`~.estimator.run_online_cars` gives one with
    a leading car axis on every array.

    Attributes
    ----------
    state : FilterState
        The state after the last step: where a run over the car's next stream starts.
    trajectory : OnlineSummary
        The estimate at every step (each field with a leading step axis;
        :meth:`OnlineSummary.to_dict` reads a step).

    Examples
    --------
    An estimator's state before any window, and its summary as a trajectory of one step:

    >>> import equinox as eqx
    >>> import jax
    >>> from tyrebayes import OnlineEstimator
    >>> estimator = OnlineEstimator.create(model="linear")
    >>> state = estimator.init()
    >>> first = eqx.filter_jit(estimator.summary)(state)
    >>> run = OnlineRun(state=state, trajectory=jax.tree.map(lambda x: x[None], first))
    >>> out = run.to_dict()
    >>> list(out), len(out["trajectory"]), out["final"]["enough_evidence"]
    (['trajectory', 'final', 'alarms_s', 'alarm_kinds'], 1, False)
    """

    state: FilterState
    trajectory: OnlineSummary

    @property
    def n_steps(self) -> int:
        """Steps in the trajectory."""
        return int(np.shape(self.trajectory.time_s)[-1])

    def to_dict(self) -> dict:
        """The estimator's part of ``tyrebayes online --json``: ``"trajectory"`` (every step's
        :meth:`OnlineSummary.to_dict`), ``"final"`` (the last step's), and ``"alarms_s"`` and
        ``"alarm_kinds"`` (the steps with an alarm: time [s] and "swap" or "change").

        Raises
        ------
        ValueError
            For a run over many cars (:func:`~.estimator.run_online_cars`): one car at a time.
        """
        shape = np.shape(self.trajectory.time_s)
        if len(shape) != 1:
            raise ValueError(
                f"OnlineRun.to_dict: expected one car's trajectory (steps,), got shape {shape}"
            )
        records = [self.trajectory.to_dict(i) for i in range(self.n_steps)]
        return {
            "trajectory": records,
            "final": records[-1],
            "alarms_s": [r["time_s"] for r in records if r["alarm"]],
            "alarm_kinds": [r["alarm_kind"] for r in records if r["alarm"]],
        }


__all__ = ["OnlineRun"]
