"""A bounded sample of a long log for its per-channel statistics: runs of consecutive samples.

A channel's period, its dropped fraction, its quantisation step and its white-noise sd are
properties of the sensor and its encoding, not of the drive, and a few thousand samples pin
them (the median absolute deviation of n independent Gaussian values has a relative sd of about
1.2/√n); an hour at 100 Hz has 360,000. Read on up to 100,000 samples each, they set the cost of
the per-drive stage's validate step: on 20,000 it took 0.096 CPU s per simulated drive-hour
against 0.161 (``benchmarks/results/drive_stage_profile.json``). The sample is runs of
consecutive samples spread evenly over the log, not every k-th sample: the statistics need
neighbours (intervals, second differences, adjacent quantisation levels), and CAN timing jitters
in patterns (short and long intervals in turn) of which every k-th interval can see one phase
only.

Examples
--------
>>> import numpy as np
>>> runs = sample_runs(np.arange(1_000_000.0))
>>> runs.shape, float(runs[1, 0] - runs[0, 0]) > runs.shape[1]
((64, 312), True)
>>> sample_runs(np.arange(5.0)).shape  # a short log is its own sample
(1, 5)
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Float

#: At most this many samples of a log are read for a per-channel statistic ...
SAMPLE_SIZE = 20_000
#: ... in this many runs of consecutive samples, spread evenly over the log.
SAMPLE_RUNS = 64


def sample_runs(
    x: Float[np.ndarray, "n"], size: int = SAMPLE_SIZE, runs: int = SAMPLE_RUNS
) -> Float[np.ndarray, "runs length"]:
    """``x`` as one run (a view) if it has at most ``size`` samples, else ``runs`` runs of
    ``size // runs`` consecutive samples, spread evenly from its start to its end (a copy).

    Parameters
    ----------
    x : ndarray, shape (n,)
        One channel's samples (or intervals) in log order.
    size, runs : int
        The sample's size at most, and its number of runs.

    Returns
    -------
    ndarray, shape (runs, length)
        One run per row: differences along axis 1 are between neighbours in the log.
    """
    if x.size <= size:
        return x[None, :]
    length = size // runs
    starts = np.linspace(0, x.size - length, runs).astype(np.int64)
    return x[starts[:, None] + np.arange(length)]


__all__ = ["SAMPLE_RUNS", "SAMPLE_SIZE", "sample_runs"]
