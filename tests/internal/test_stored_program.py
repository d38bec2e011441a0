"""A jitted function's program kept on disk: read back without tracing, same results."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.internal.jax_cache import point_compilation_cache
from tyrebayes.internal.stored_program import stored_program


@jax.jit
def _function(x, data):
    return x * data["a"], {"total": jnp.sum(data["b"]) + x.sum(), "code": jnp.argmax(data["b"])}


def _args(n=3):
    x = jnp.arange(n, dtype=float)
    return x, {"a": jnp.full(n, 2.0), "b": jnp.asarray([1.0, 5.0, 2.0])}


def _same(got, want):
    for g, w in zip(jax.tree.leaves(got), jax.tree.leaves(want), strict=True):
        np.testing.assert_array_equal(np.asarray(g), np.asarray(w))
    assert jax.tree.structure(got) == jax.tree.structure(want)


def test_a_new_process_reads_the_program_instead_of_tracing(compilation_cache_dir):
    want = _function.__wrapped__(*_args())
    first = stored_program(_function, ("test", 1))
    _same(first(*_args()), want)
    files = list((compilation_cache_dir / "tyrebayes-programs").glob("*.jaxexport"))
    assert len(files) == 1

    # A second wrapper stands for a new process: it reads the file and does not trace.
    exports, export = [], jax.export.export

    def counted(*args, **kwargs):
        exports.append(1)
        return export(*args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(jax.export, "export", counted)
        _same(stored_program(_function, ("test", 1))(*_args()), want)
        assert exports == []
        # ... where a process without the file traces (the count sees it).
        (compilation_cache_dir / "tyrebayes-programs" / files[0].name).unlink()
        stored_program(_function, ("test", 1))(*_args())
        assert exports == [1]
    # Other shapes or another key: another program.
    stored_program(_function, ("test", 1))(*_args(4)[:1], {"a": jnp.ones(4), "b": jnp.ones(3)})
    stored_program(_function, ("test", 2))(*_args())
    assert len(list((compilation_cache_dir / "tyrebayes-programs").glob("*.jaxexport"))) == 3


def test_a_file_that_is_not_a_program_is_replaced(compilation_cache_dir):
    stored_program(_function, ("corrupt",))(*_args())
    (path,) = (compilation_cache_dir / "tyrebayes-programs").glob("*.jaxexport")
    path.write_bytes(b"not a program")
    _same(stored_program(_function, ("corrupt",))(*_args()), _function.__wrapped__(*_args()))
    assert path.read_bytes() != b"not a program"


def test_without_a_cache_folder_the_function_is_called_as_it_is():
    point_compilation_cache(None)
    _same(stored_program(_function, ("none",))(*_args()), _function.__wrapped__(*_args()))


def test_a_program_traced_from_other_source_is_not_read(compilation_cache_dir, monkeypatch):
    import tyrebayes.internal.stored_program as module

    stored_program(_function, ("source",))(*_args())
    monkeypatch.setattr(module, "source_fingerprint", lambda: "other source")
    _same(stored_program(_function, ("source",))(*_args()), _function.__wrapped__(*_args()))
    assert len(list((compilation_cache_dir / "tyrebayes-programs").glob("*.jaxexport"))) == 2


def test_results_mix_with_arrays_spread_over_several_devices(compilation_cache_dir):
    # NUTS runs its chains on several devices and combines them with the Laplace core's
    # results: an exported program's results come committed to one device, which must not leak.
    from jax.sharding import Mesh, NamedSharding, PartitionSpec

    for _ in range(2):  # exported, then read back
        out = stored_program(_function, ("devices",))(*_args())
        assert all(isinstance(leaf, np.ndarray) for leaf in jax.tree.leaves(out))
        devices = jax.devices()
        if len(devices) < 2:
            continue
        mesh = Mesh(np.asarray(devices[:2]), ("d",))
        spread = jax.device_put(jnp.ones((2, 3)), NamedSharding(mesh, PartitionSpec("d")))
        np.testing.assert_allclose(np.asarray(spread @ out[0]), np.full(2, 6.0))  # x·a = 0+2+4
