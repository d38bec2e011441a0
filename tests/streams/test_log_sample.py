"""The bounded sample of a long log: runs of consecutive samples spread over it."""

import numpy as np
import pytest

from tyrebayes.streams.log_sample import SAMPLE_RUNS, SAMPLE_SIZE, sample_runs
from tyrebayes.streams.noise import quantisation_step, white_noise_sd
from tyrebayes.streams.resample import _median_interval


def test_a_short_log_is_its_own_sample_without_a_copy():
    x = np.arange(float(SAMPLE_SIZE))
    runs = sample_runs(x)
    assert runs.shape == (1, SAMPLE_SIZE)
    assert np.shares_memory(runs, x)


@pytest.mark.parametrize("n", [SAMPLE_SIZE + 1, 360_000, 3_600_001])
def test_a_long_log_gives_runs_of_neighbours_from_its_start_to_its_end(n):
    x = np.arange(float(n))
    runs = sample_runs(x)
    length = SAMPLE_SIZE // SAMPLE_RUNS
    assert runs.shape == (SAMPLE_RUNS, length)
    assert np.all(np.diff(runs, axis=1) == 1.0)  # consecutive samples within a run
    assert runs[0, 0] == 0.0 and runs[-1, -1] == n - 1.0
    gaps = np.diff(runs[:, 0])
    assert gaps.min() >= length and gaps.max() - gaps.min() <= 1.0  # evenly spread, apart


def test_statistics_of_a_long_log_from_its_sample():
    """An hour at 100 Hz: the period of jittered time stamps, a CAN wheel speed's step and the
    white noise of a smooth signal."""
    rng = np.random.default_rng(5)
    t = np.cumsum(0.01 + rng.normal(0.0, 1e-4, 360_000))
    assert _median_interval(t) == pytest.approx(0.01, abs=1e-5)
    step = 0.01 / 3.6 / 0.35
    speed = np.round((20 + np.cumsum(rng.normal(0, 0.005, 360_000))) / step) * step
    assert quantisation_step(speed) == pytest.approx(step, rel=1e-9)
    t = np.arange(360_000) * 0.01
    x = 10 * np.sin(2 * np.pi * 0.05 * t) + rng.normal(0, 0.05, t.size)
    assert white_noise_sd(x) == pytest.approx(0.05, rel=0.03)
