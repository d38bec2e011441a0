"""Host data into JAX arrays without a compiled program per shape.

Outside a trace, ``jnp.asarray`` and ``jnp.array`` of a NumPy array lift it with ``lax.stage``,
an eager primitive that JAX compiles (and looks up in the persistent cache) once per shape and
dtype, and again after a worker drops its compiled programs. A drive's arrays have the drive's
own length, so every drive paid a compilation for each array it handed to JAX.
:func:`device_array` copies the data to the device instead (``jax.device_put``, no program):
the same values, dtype and shape. ``benchmarks/results/drive_stage_profile.json`` has the
per-drive stage's cost with it.

Examples
--------
>>> import numpy as np
>>> x = device_array(np.arange(3.0))
>>> x.dtype.name, x.shape, bool(x.weak_type)
('float64', (3,), False)
>>> device_array([True, False]).dtype.name
'bool'
"""

from __future__ import annotations

import jax
import numpy as np


def device_array(x, dtype=None) -> jax.Array:
    """``x`` (a NumPy array, a sequence, or a JAX array) as a JAX array of ``dtype``.

    Parameters
    ----------
    x : array_like
        Host data; a JAX array of the asked dtype is returned as it is. Not for traced values
        (inside ``jax.jit`` use ``jnp.asarray``, which costs nothing there).
    dtype : dtype, optional
        The array's dtype; default the data's own (as ``np.asarray`` makes it).

    Returns
    -------
    jax.Array
        On the default device, uncommitted and strongly typed, as ``jnp.asarray`` of a NumPy
        array gives it.
    """
    if isinstance(x, jax.Array) and (dtype is None or x.dtype == np.dtype(dtype)):
        return x
    return jax.device_put(np.asarray(x, dtype=dtype))


__all__ = ["device_array"]
