"""Step 4 of :mod:`tyrebayes.simulate.drive`: the tyres' temperatures along the drive."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..physics.thermal import ThermalParams, simulate_tyre_temperature

_thermal_jit = eqx.filter_jit(
    jax.vmap(simulate_tyre_temperature, in_axes=(None, None, 1, 1, 1, None, None), out_axes=1)
)


def _temperatures(
    thermal: ThermalParams,
    dt: float,
    v: np.ndarray,
    fz: np.ndarray,
    friction_w: np.ndarray,
    ambient_c: float,
    initial_c: float,
) -> np.ndarray:
    """Tyre temperatures (n, 4) [°C]: the thermal model on 1 s block means, interpolated.

    The tyre's thermal time constant is minutes, so 1 Hz loses nothing and keeps the scan short.
    """
    n = len(v)
    block = max(int(round(1.0 / dt)), 1)
    nb = max(n // block, 1)
    cut = nb * block if n >= block else n

    def means(x):
        x = x[:cut]
        return x.reshape(nb, -1, *x.shape[1:]).mean(axis=1)

    t_blocks = np.arange(nb) * block * dt
    speed_b = np.repeat(means(np.abs(v))[:, None], 4, axis=1)
    temps = np.asarray(
        _thermal_jit(
            thermal,
            jnp.asarray(t_blocks),
            jnp.asarray(speed_b),
            jnp.asarray(means(fz)),
            jnp.asarray(means(friction_w)),
            # Arrays, not floats: a float is a static argument of filter_jit (one scan per value).
            jnp.asarray(float(ambient_c)),
            jnp.asarray(float(initial_c)),
        )
    )
    if nb == 1:
        return np.broadcast_to(temps[0], (n, 4)).copy()
    # Block means describe block centres; the first block starts at the initial temperature.
    t = np.arange(n) * dt
    return np.stack([np.interp(t, t_blocks, temps[:, i]) for i in range(4)], axis=1)
