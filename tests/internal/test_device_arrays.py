"""Host data to JAX arrays: what ``jnp.asarray`` gives, without a compiled program per shape."""

import logging

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.internal.device_arrays import device_array


@pytest.mark.parametrize(
    "x",
    [np.arange(5.0), np.arange(6).reshape(2, 3), np.array([True, False]), np.float64(2.5)],
    ids=["float", "int 2-d", "bool", "0-d"],
)
def test_values_dtype_shape_and_typing_match_jnp_asarray(x):
    ours, theirs = device_array(x), jnp.asarray(x)
    assert isinstance(ours, jax.Array)
    assert (ours.dtype, ours.shape, ours.weak_type) == (theirs.dtype, theirs.shape, False)
    assert ours.committed == theirs.committed
    np.testing.assert_array_equal(np.asarray(ours), np.asarray(theirs))


def test_a_dtype_converts_and_a_jax_array_of_that_dtype_passes_through():
    assert device_array([1, 2], np.float64).dtype == jnp.float64
    x = jnp.arange(3.0)
    assert device_array(x) is x and device_array(x, x.dtype) is x
    assert device_array(x, np.int32).dtype == jnp.int32


def test_a_new_shape_compiles_nothing(caplog):
    # jnp.asarray would compile (or load from the cache) a program for each new shape.
    jax.config.update("jax_log_compiles", True)
    try:
        with caplog.at_level(logging.WARNING, logger="jax"):
            for n in (3001, 3002, 3003):
                device_array(np.ones(n))
    finally:
        jax.config.update("jax_log_compiles", False)
    assert not [r for r in caplog.records if "Compiling" in r.getMessage()]
