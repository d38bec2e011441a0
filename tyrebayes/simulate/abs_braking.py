"""Step 6 of :mod:`tyrebayes.simulate.drive`: ABS events, where the tyres decide the
deceleration (slip cycled around the peak) and the planned speed gives way.
"""

from __future__ import annotations

import numpy as np

from ..physics.vehicle import AIR_DENSITY_KGPM3, GRAVITY_MPS2, Vehicle
from .drive_forces import MIN_SLIP_SPEED_MPS, wheel_loads_np
from .profiles import LONG_LABELS, DriveProfile
from .tyre_curves import peak_slip, tyre_force
from .tyre_spec import TyreSpec

_ABS = LONG_LABELS.index("abs")


#: ABS cycle: slip between (1 − ABS_SWING) and (1 + ABS_SWING) times the peak slip, at ABS_HZ.
ABS_SWING = 0.5


ABS_HZ = 4.0


def _abs_slip_pattern(rng: np.random.Generator, m: int, dt: float) -> np.ndarray:
    """Slip of each wheel relative to its peak slip during one ABS event, shape (m, 4), ≤ 0.

    Sawtooth-like cycles (slow pressure build-up, fast release) from three Fourier terms, between
    (1 − ABS_SWING) and (1 + ABS_SWING) times the peak, after a 0.15 s entry ramp.
    """
    t = np.arange(m)[:, None] * dt
    freq = ABS_HZ * rng.uniform(0.85, 1.15, 4)
    phase = rng.uniform(0, 1, 4)
    x = freq * t + phase
    saw = -(2 / np.pi) * sum(np.sin(2 * np.pi * k * x) / k for k in (1, 2, 3))
    saw = saw / 1.2  # the three-term sum overshoots ±1 slightly (Gibbs)
    ramp = np.clip(t / 0.15, 0.0, 1.0)
    return -ramp * (1.0 + ABS_SWING * np.clip(saw, -1.0, 1.0))


def _apply_abs(
    rng: np.random.Generator,
    profile: DriveProfile,
    vehicle: Vehicle,
    tyre: TyreSpec,
    tyre_model: str,
    mu: float,
    c_x_wheel: np.ndarray,
    fz_static: np.ndarray,
    v: np.ndarray,
    a: np.ndarray,
    grade: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Replace planned ABS decelerations by the tyres' (fixed point over load transfer).

    Returns the new speed, acceleration and an (n, 4) array of prescribed slips (NaN outside ABS).
    """
    dt = profile.dt_s
    g, m = GRAVITY_MPS2, vehicle.mass_kg
    v, a = v.copy(), a.copy()
    slip = np.full((len(v), 4), np.nan)
    for ev in profile.abs_events:
        s0, s1, s2 = ev.start, ev.stop, ev.recovery_stop
        k = s1 - s0
        if k < 2:
            continue
        rel = _abs_slip_pattern(rng, k, dt)
        cx = c_x_wheel[s0:s1]
        acc = np.full(k, -0.9 * mu * g)
        v_ev = v[s0:s1]
        for _ in range(6):
            fz = (
                wheel_loads_np(vehicle, acc + g * np.sin(grade[s0:s1]), 0.0)
                * np.cos(grade[s0:s1])[:, None]
            )
            s_pk = peak_slip(tyre_model, fz, cx, mu, tyre, fz_static[None, :])
            sl = rel * s_pk
            rho = tyre_force(tyre_model, sl, fz, cx, mu, tyre, fz_static[None, :])
            resist = (
                0.5 * AIR_DENSITY_KGPM3 * vehicle.drag_area_m2 * v_ev**2
                + vehicle.rolling_resistance * m * g * np.cos(grade[s0:s1])
                + m * g * np.sin(grade[s0:s1])
            )
            acc = ((rho * fz).sum(axis=1) - resist) / m
            v_start = v[s0 - 1] if s0 > 0 else v[s0]
            v_ev = np.maximum(v_start + np.cumsum(acc) * dt, MIN_SLIP_SPEED_MPS)
        slip[s0:s1] = sl
        # Recovery: absorb the speed difference so the drive continues as planned.
        seg_a = a[s0:s2].copy()
        seg_a[:k] = acc
        v_start = v[s0 - 1] if s0 > 0 else v[s0]
        target_end = v[s2 - 1]
        n_rec = s2 - s1
        if n_rec > 0:
            mismatch = v_start + seg_a.sum() * dt - target_end
            seg_a[k:] -= mismatch / (n_rec * dt)
        v[s0:s2] = np.maximum(v_start + np.cumsum(seg_a) * dt, MIN_SLIP_SPEED_MPS)
        a[s0:s2] = seg_a
    return v, a, slip
