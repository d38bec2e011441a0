"""Tyre-change detection: a step is found, a history without one keeps its false-alarm rate."""

import numpy as np
import pytest

from tyrebayes.inference.wear.changepoint import (
    FALSE_ALARM_RATE,
    detect_tyre_changes,
    step_threshold,
)


def _history(rng, n=40, noise=0.05, slope=-2e-5):
    x = rng.uniform(1e4, 3e4, n)  # interval work difference [J]
    y = np.concatenate([[0.0], np.cumsum(slope * x[:-1])]) + noise * rng.standard_normal(n)
    return y, x


def test_a_step_is_found_where_it_is():
    rng = np.random.default_rng(0)
    y, x = _history(rng)
    y[23:] += 1.0  # 20 noise sd
    changes = detect_tyre_changes(y, x)
    assert changes.index.tolist() == [23]
    assert changes.statistic[0] > changes.threshold


def test_a_single_bad_drive_is_not_a_step():
    rng = np.random.default_rng(1)
    y, x = _history(rng)
    y[17] += 1.0
    assert detect_tyre_changes(y, x).index.size == 0


def test_false_alarm_rate_holds_without_a_change():
    """1000 Gaussian histories of 40 drives: alarms <= 1 % + 3 binomial sd."""
    rng = np.random.default_rng(2)
    alarms = sum(detect_tyre_changes(*_history(rng)).index.size > 0 for _ in range(1000))
    bound = FALSE_ALARM_RATE + 3 * np.sqrt(FALSE_ALARM_RATE * (1 - FALSE_ALARM_RATE) / 1000)
    assert alarms / 1000 <= bound


def test_rotation_and_replacement_are_told_apart():
    """After ~1 mm of drift a rotation moves y by ~2 mm, a replacement by ~1 mm."""
    rng = np.random.default_rng(3)
    n = 40
    x = np.full(n, 2.5e4)
    drift = np.concatenate([[0.0], np.cumsum(np.full(n - 1, -2e-6) * x[:-1])])  # -0.05 mm/drive
    y = drift.copy()
    y[20:] = y[20:] - 2 * drift[19]  # rotation: the worn pair goes to the rear
    y[32:] = drift[32:] - drift[31]  # replacement: new tyres
    y += 0.01 * rng.standard_normal(n)
    changes = detect_tyre_changes(y, x, radius_spread_mm=0.1)
    assert changes.index.tolist() == [20, 32]
    assert changes.change_type == ("rotation", "replacement")


def test_threshold_is_the_bonferroni_bound():
    assert step_threshold(41, 0.01) == pytest.approx(3.66, abs=0.01)
    with pytest.raises(ValueError, match="false_alarm"):
        step_threshold(10, 1.5)
