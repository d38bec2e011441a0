"""Stationary random processes of the simulator: Ornstein–Uhlenbeck noise and a smooth variant.

The driver's speed wander (:mod:`tyrebayes.simulate.profiles`) and the sensors' drifts
(:mod:`tyrebayes.simulate.sensors`) are drawn from them.
"""

from __future__ import annotations

import numpy as np


def ou_process(rng: np.random.Generator, n: int, dt: float, tau_s: float, sd: float) -> np.ndarray:
    """Stationary Ornstein–Uhlenbeck samples (exact AR(1) discretisation), vectorised via lfilter.

    Examples
    --------
    >>> x = ou_process(np.random.default_rng(1), 200_000, 0.01, 1.0, 2.0)
    >>> bool(abs(x.std() - 2.0) < 0.2)
    True
    """
    from scipy.signal import lfilter

    phi = float(np.exp(-dt / tau_s))
    innov = rng.standard_normal(n) * sd * np.sqrt(1.0 - phi**2)
    innov[0] = rng.standard_normal() * sd  # start in the stationary distribution
    return lfilter([1.0], [1.0, -phi], innov)


def smooth_noise(
    rng: np.random.Generator, n: int, dt: float, tau_s: float, sd: float
) -> np.ndarray:
    """Smooth stationary noise: an OU process passed through a second AR(1) stage, rescaled to sd.

    Unlike the OU process itself it has a finite derivative (sd ≈ sd/τ), so speeds built from it
    have plausible accelerations.

    Examples
    --------
    >>> x = smooth_noise(np.random.default_rng(1), 100_000, 0.01, 2.0, 0.5)
    >>> bool(abs(x.std() - 0.5) < 0.15) and bool(np.abs(np.diff(x)).max() / 0.01 < 2.0)
    True
    """
    from scipy.signal import lfilter

    if n == 0 or sd == 0:
        return np.zeros(n)
    phi = float(np.exp(-dt / tau_s))
    x = ou_process(rng, n, dt, tau_s, 1.0)
    # Start the second stage at the first stage's value: no transient at t = 0.
    y, _ = lfilter([1.0 - phi], [1.0, -phi], x, zi=[phi * x[0]])
    # Stationary sd of a unit-variance AR(1) passed through (1 − φ)/(1 − φB): √(1 + φ²)/(1 + φ).
    return y * (sd * (1 + phi) / np.sqrt(1 + phi**2))
