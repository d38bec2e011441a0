"""The CUSUM's recursion: Page's two sides, the gate and the cap on one step's evidence."""

from __future__ import annotations

import jax.numpy as jnp

from tyrebayes.inference.online.change import cusum_step


def _run(increments, **kwargs):
    up = down = jnp.zeros(())
    alarms = []
    for g in increments:
        up, down, alarm = cusum_step(
            jnp.asarray([g, -g]), up, down, armed=jnp.array(True), **kwargs
        )
        alarms.append(bool(alarm))
    return float(up), alarms


def test_one_step_alone_cannot_alarm_past_the_cap():
    # h = 10, at most 3 steps: one ratio counts at most 10/2.5 = 4.
    _, alarms = _run([50.0], threshold=10.0, max_increment=4.0)
    assert alarms == [False]
    _, alarms = _run([50.0, 50.0, 50.0], threshold=10.0, max_increment=4.0)
    assert alarms == [False, False, True]
    # Without the cap the first step alarms.
    _, alarms = _run([50.0], threshold=10.0)
    assert alarms == [True]


def test_negative_evidence_resets_and_an_unarmed_step_holds_zero():
    up, _ = _run([3.0, -5.0], threshold=10.0)
    assert up == 0.0
    up, down, alarm = cusum_step(
        jnp.asarray([30.0, 1.0]),
        jnp.asarray(5.0),
        jnp.zeros(()),
        armed=jnp.array(False),
        threshold=10.0,
    )
    assert float(up) == 0.0 and not bool(alarm)
