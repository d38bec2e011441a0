"""Tests of the shared JAX compilation cache switch (tyrebayes.internal.jax_cache)."""

import jax
import jax.numpy as jnp

from tyrebayes.internal.jax_cache import (
    default_cache_dir,
    enable_compilation_cache,
    point_compilation_cache,
)


def test_environment_chooses_the_folder_and_empty_switches_it_off(monkeypatch, tmp_path):
    monkeypatch.setenv("TYREBAYES_JAX_CACHE", str(tmp_path / "c"))
    assert default_cache_dir() == str(tmp_path / "c")
    monkeypatch.delenv("TYREBAYES_JAX_CACHE")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_cache_dir() == str(tmp_path / "tyrebayes" / "jax")
    monkeypatch.setenv("TYREBAYES_JAX_CACHE", "")
    assert enable_compilation_cache() == ""


def test_enabling_points_jax_at_a_created_folder(tmp_path):
    folder = tmp_path / "nested" / "cache"
    assert enable_compilation_cache(str(folder)) == str(folder)
    assert folder.is_dir()
    assert jax.config.jax_compilation_cache_dir == str(folder)
    assert jax.config.jax_persistent_cache_min_compile_time_secs == 0.0
    assert jax.config.jax_persistent_cache_min_entry_size_bytes == 0


def test_a_folder_that_cannot_be_made_runs_without_cache(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    before = jax.config.jax_compilation_cache_dir
    assert enable_compilation_cache(str(blocker / "cache")) == ""
    assert jax.config.jax_compilation_cache_dir == before


def _entries(folder):
    return {path.name for path in folder.iterdir() if path.is_file()}


def test_switching_the_cache_off_stops_its_writes_at_once(tmp_path):
    # JAX keeps the folder it opened first whatever its configuration says afterwards.
    enable_compilation_cache(str(tmp_path))
    jax.jit(lambda x: x + 1.0)(jnp.ones(3))
    written = _entries(tmp_path)
    assert written, "the cache wrote nothing"
    point_compilation_cache(None)
    jax.jit(lambda x: 3.0 * x - 2.0)(jnp.ones(5))
    assert _entries(tmp_path) == written
