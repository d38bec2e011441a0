"""Synthetic windows of the linear slip model for the online estimator's tests."""

from __future__ import annotations

import numpy as np

from tyrebayes.inference.tyre.data import WindowTable


def linear_windows(
    seed: int,
    duration_s: float,
    *,
    c_x: float = 40.0,
    c_x_after: float | None = None,
    change_s: float | None = None,
    force_range: tuple[float, float] = (0.03, 0.3),
    slip_offset: float = 0.002,
    slip_sd: float = 2e-4,
    rho_sd: float = 0.005,
    start_s: float = 0.0,
    load_sensitivity: float = 0.0,
) -> WindowTable:
    """Windows every 0.25 s: slip = ρ/C_x + offset + noise, force uniform in ``force_range``.

    The driven axle unloads as it pushes, ΔF_z/F_z = −0.5 ρ, and C_x follows it through
    ``load_sensitivity`` (C_x exp(q ΔF_z/F_z)).
    """
    rng = np.random.default_rng(seed)
    t = start_s + 0.125 + 0.25 * np.arange(int(duration_s / 0.25))
    rho_true = rng.uniform(*force_range, t.size)
    stiffness = np.full(t.size, c_x)
    if c_x_after is not None:
        stiffness[t >= change_s] = c_x_after
    load_change = -0.5 * rho_true
    stiffness = stiffness * np.exp(load_sensitivity * load_change)
    n = t.size
    return WindowTable(
        slip=rho_true / stiffness + slip_offset + rng.normal(0.0, slip_sd, n),
        rho=rho_true + rng.normal(0.0, rho_sd, n),
        slip_sd=np.full(n, slip_sd),
        rho_sd=np.full(n, rho_sd),
        temperature_c=np.full(n, 20.0),
        time_s=t,
        load_change=load_change,
        at_limit=np.zeros(n, dtype=bool),
    )
