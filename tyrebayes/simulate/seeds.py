"""The simulator's seeds: one seed (an int or a JAX key) split into independent streams.

The profile, the sensor offsets, the sensor noise, the ABS cycles and the tyre curve of
:func:`~tyrebayes.simulate.drive.simulate_drive` each use their own stream, so changing one
leaves the others as they were.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ..physics.tyre import MagicFormulaLongitudinal
from .tyre_spec import draw_database_curve


def seed_sequence(key_or_seed) -> np.random.SeedSequence:
    """A NumPy seed sequence from an int seed or a JAX PRNG key (raw or typed)."""
    if isinstance(key_or_seed, int | np.integer):
        return np.random.SeedSequence(int(key_or_seed))
    key = jnp.asarray(key_or_seed)
    if jax.dtypes.issubdtype(key.dtype, jax.dtypes.prng_key):
        key = jax.random.key_data(key)
    return np.random.SeedSequence(np.asarray(key, dtype=np.uint32).ravel().tolist())


def drawn_curve(key_or_seed) -> MagicFormulaLongitudinal:
    """The Magic Formula shape :func:`simulate_drive` draws for a tyre given by its type.

    From the fifth of the seed's five streams (:func:`simulate_drive` calls this): a benchmark
    can change this curve (its load dependences, say) and simulate the same drive with it.
    """
    return draw_database_curve(np.random.default_rng(seed_sequence(key_or_seed).spawn(5)[4]))


def _seed_int(key_or_seed) -> int:
    return int(seed_sequence(key_or_seed).generate_state(1)[0])
