"""A stream's online run as the command prints it: every step's record, the last, the alarms."""

import equinox as eqx
import jax
import jax.numpy as jnp
import pytest

from tyrebayes.inference.online import OnlineEstimator
from tyrebayes.inference.online.run import OnlineRun


@pytest.fixture(scope="module")
def run():
    """Three steps of the prior's summary, an alarm (a swap) at the second."""
    estimator = OnlineEstimator.create(model="linear")
    state = estimator.init()
    first = eqx.filter_jit(estimator.summary)(state)
    trajectory = jax.tree.map(lambda x: jnp.stack([x, x, x]), first)
    trajectory = eqx.tree_at(
        lambda s: (s.time_s, s.alarm, s.swap_alarm),
        trajectory,
        (jnp.asarray([30.0, 60.0, 90.0]), jnp.asarray([False, True, False]), jnp.ones(3, bool)),
    )
    return OnlineRun(state=state, trajectory=trajectory)


def test_to_dict_is_the_commands_trajectory_part(run):
    out = run.to_dict()
    assert list(out) == ["trajectory", "final", "alarms_s", "alarm_kinds"]
    assert [r["time_s"] for r in out["trajectory"]] == [30.0, 60.0, 90.0]
    assert out["trajectory"][1] == run.trajectory.to_dict(1)
    assert out["final"] == out["trajectory"][-1]
    assert out["alarms_s"] == [60.0] and out["alarm_kinds"] == ["swap"]


def test_many_cars_are_refused(run):
    cars = jax.tree.map(lambda x: jnp.stack([x, x]), run)
    with pytest.raises(ValueError, match=r"expected one car's trajectory \(steps,\), got shape"):
        cars.to_dict()
