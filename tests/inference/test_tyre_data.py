"""Window observations: stacking drives, ABS windows and the features' window selection."""

import numpy as np

from tyrebayes.inference.tyre_data import stack_drives


def test_stacked_abs_windows_get_no_score():
    rng = np.random.default_rng(2)
    n = 40
    windows = {
        "slip": rng.normal(0.002, 0.001, n),
        "rho": np.concatenate([rng.normal(0.05, 0.02, n - 5), np.full(5, -0.9)]),
        "slip_sd": np.full(n, 1e-3),
        "rho_sd": np.full(n, 0.01),
        "temperature_c": np.full(n, 20.0),
        "neighbour_slip": np.zeros(n),
        "at_limit": np.arange(n) >= n - 5,
    }
    obs = stack_drives([windows], ["dry"])
    score = np.asarray(obs.rho_score)
    assert np.all(score[n - 5 : n] == 0.0) and np.all(score[n:] == 0.0)
    assert np.all(np.isfinite(score[: n - 5])) and np.any(score[: n - 5] != 0.0)
