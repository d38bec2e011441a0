"""Window observations: stacking drives, ABS windows and the features' window selection."""

import numpy as np

from tyrebayes.inference.tyre.data import WindowTable, stack_drives
from tyrebayes.streams.abs_detection import _below_run_peak, wheel_oscillation


def test_stacked_abs_windows_get_no_score():
    rng = np.random.default_rng(2)
    n = 40
    windows = WindowTable(
        slip=rng.normal(0.002, 0.001, n),
        rho=np.concatenate([rng.normal(0.05, 0.02, n - 5), np.full(5, -0.9)]),
        slip_sd=np.full(n, 1e-3),
        rho_sd=np.full(n, 0.01),
        temperature_c=np.full(n, 20.0),
        time_s=0.25 * np.arange(n),
        neighbour_slip=np.zeros(n),
        at_limit=np.arange(n) >= n - 5,
    )
    obs = stack_drives([windows], ["dry"])
    score = np.asarray(obs.rho_score)
    assert np.all(score[n - 5 : n] == 0.0) and np.all(score[n:] == 0.0)
    assert np.all(np.isfinite(score[: n - 5])) and np.any(score[: n - 5] != 0.0)


def test_wheels_ramping_apart_do_not_oscillate_but_abs_cycles_do():
    """A hard stop without ABS ramps the wheels apart (1 m/s in a second): that is not ABS, though
    a window's plain sd of the wheel speeds is as large as ABS's (recovery seed 1003 read a
    0.7 g stop as ABS). A 4 Hz cycle of ±0.15 m/s is."""
    rate, n = 100.0, 400
    t = np.arange(n) / rate
    ramp = np.zeros((n, 4))
    ramp[:, 2] = -np.clip(t - 1.0, 0.0, 1.0)  # one wheel slips 1 m/s more over a second
    cycle = np.zeros((n, 4))
    cycle[:, 2] = 0.15 * np.sin(2 * np.pi * 4.0 * t)
    valid = np.ones(n, bool)
    inner = slice(5, 11)  # windows 1.25-2.75 s: away from the edges of the moving average
    ramp_osc = wheel_oscillation(ramp, valid, 25, rate)[inner]
    cycle_osc = wheel_oscillation(cycle, valid, 25, rate)[inner]
    plain_ramp_sd = np.std(ramp[125:150, 2])  # what a window's plain sd reads in the ramp
    assert np.max(ramp_osc) < 0.2 * np.min(cycle_osc)
    assert plain_ramp_sd > 0.5 * np.min(cycle_osc)


def test_abs_runs_lose_their_entry_window():
    at_limit = np.array([False, True, True, True, True, False, True, True, True])
    rho = np.array([0.0, -0.79, -0.95, -0.96, -0.95, 0.0, -1.1, -1.1, -1.12])
    kept = _below_run_peak(at_limit, rho)
    np.testing.assert_array_equal(kept, at_limit & (np.arange(9) != 1))
