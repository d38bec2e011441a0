"""Strict test configuration: float64, no silent rank promotion, fixed seeds."""

import gc
import os

os.environ.setdefault("XLA_FLAGS", "--xla_force_host_platform_device_count=2")
os.environ.setdefault("MPLBACKEND", "Agg")
# No persistent compilation cache for what the suite runs (the commands it calls would switch it
# on in this process): a test neither reads the user's cache nor fills it. The tests of the
# cache and of the stored programs point JAX at a folder of their own (`compilation_cache_dir`),
# and `_no_cache_left_behind` switches it off again after every test.
os.environ.setdefault("TYREBAYES_JAX_CACHE", "")

import jax  # noqa: E402
import pytest  # noqa: E402

from tyrebayes.internal.jax_cache import point_compilation_cache  # noqa: E402

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

_CACHE_SETTINGS = (
    "jax_compilation_cache_dir",
    "jax_persistent_cache_min_compile_time_secs",
    "jax_persistent_cache_min_entry_size_bytes",
)


@pytest.fixture(autouse=True, scope="module")
def _compiled_programs_dropped_after_each_module():
    """Each compiled program keeps a few memory mappings for as long as JAX caches it; a whole
    suite in one process accumulated them towards the kernel's limit (vm.max_map_count, 65,530)
    and XLA then crashed in its next compilation or serialisation. Dropping them after each
    module bounds the count by the largest module's."""
    yield
    jax.clear_caches()
    gc.collect()


@pytest.fixture(autouse=True)
def _no_cache_left_behind():
    """Whatever a test did to JAX's persistent cache is undone, and the cache really reopened:
    JAX keeps the folder it opened first whatever its configuration says afterwards."""
    before = {name: getattr(jax.config, name) for name in _CACHE_SETTINGS}
    yield
    after = {name: getattr(jax.config, name) for name in _CACHE_SETTINGS}
    if after != before:
        for name, value in before.items():
            jax.config.update(name, value)
        point_compilation_cache(before["jax_compilation_cache_dir"])


@pytest.fixture
def compilation_cache_dir(tmp_path):
    """JAX's persistent compilation cache in a folder of this test's own (off again after it)."""
    point_compilation_cache(str(tmp_path))
    return tmp_path
