"""Strict test configuration: float64, no silent rank promotion, fixed seeds."""

import atexit
import gc
import os
import shutil
import subprocess
import sys
import tempfile

# XLA:CPU's default code generator (its MLIR fusion emitters) takes about 1.5 times as long to
# compile a fit as its older LLVM IR emitters, whose results agree to round-off
# (benchmarks/results/compile_backend.json). The suite compiles a program for nearly every test
# and runs it once, so it runs with the older emitters; set XLA_FLAGS to run it on others. A
# jaxlib that does not know the flag would abort at its first computation, so a child process
# asks first. The package, and the benchmarks of its speed and accuracy, use the default.
_SUITE_XLA_FLAGS = "--xla_force_host_platform_device_count=2"
_FAST_COMPILING = "--xla_cpu_use_fusion_emitters=false"


def _xla_accepts(flags: str) -> bool:
    try:
        probe = subprocess.run(
            [sys.executable, "-c", "import jax.numpy as jnp; jnp.zeros(1).block_until_ready()"],
            env={**os.environ, "XLA_FLAGS": flags, "JAX_PLATFORMS": "cpu"},
            capture_output=True,
            timeout=300,
        )
    except subprocess.TimeoutExpired:
        return False
    return probe.returncode == 0


if "XLA_FLAGS" not in os.environ:  # the xdist workers inherit the first process's choice
    with_emitters_off = f"{_SUITE_XLA_FLAGS} {_FAST_COMPILING}"
    os.environ["XLA_FLAGS"] = (
        with_emitters_off if _xla_accepts(with_emitters_off) else _SUITE_XLA_FLAGS
    )
os.environ.setdefault("MPLBACKEND", "Agg")
# One persistent compilation cache for the whole run, in a fresh folder removed at its end: a
# test neither reads the user's cache nor fills it, and a program that one test module (or one
# of the commands, fleet workers and pytest-xdist workers it starts, which inherit the variable)
# compiled is loaded, not compiled again, by the next, although the fixture below drops it from
# memory after each module. The run's first process makes the folder; the xdist workers it
# starts find it in their environment.
if "PYTEST_XDIST_WORKER" not in os.environ:
    _RUN_CACHE = tempfile.mkdtemp(prefix="tyrebayes-tests-jax-")
    os.environ["TYREBAYES_JAX_CACHE"] = _RUN_CACHE
    atexit.register(shutil.rmtree, _RUN_CACHE, ignore_errors=True)

import jax  # noqa: E402
import pytest  # noqa: E402

from tyrebayes.internal.jax_cache import (  # noqa: E402
    enable_compilation_cache,
    point_compilation_cache,
)

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")
enable_compilation_cache(os.environ["TYREBAYES_JAX_CACHE"])

_CACHE_SETTINGS = (
    "jax_compilation_cache_dir",
    "jax_persistent_cache_min_compile_time_secs",
    "jax_persistent_cache_min_entry_size_bytes",
)


def pytest_collection_modifyitems(items):
    """The modules marked ``early`` (minutes long: a whole command, a fit compiled cold) first.

    The parallel run hands out whole modules; one of them started last would run on alone
    while the other workers stand idle.
    """
    items.sort(key=lambda item: item.get_closest_marker("early") is None)


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
    """JAX's persistent compilation cache in a folder of this test's own (the run's again after
    it)."""
    point_compilation_cache(str(tmp_path))
    return tmp_path
