"""JAX's persistent compilation cache on disk, shared by every command and worker of a machine.

Compiling a tyre model for one data shape raises a one-hour fit's peak memory from 1.68 to
2.36 GB (``benchmarks/results/fit_memory.json``, fast path, warm against cold cache); with the
cache a second process of the same shape loads the compiled program instead.
"""

from __future__ import annotations

import os
from pathlib import Path


def default_cache_dir() -> str:
    """The cache folder: ``$TYREBAYES_JAX_CACHE``, else ``$XDG_CACHE_HOME/tyrebayes/jax``.

    Without ``$XDG_CACHE_HOME``, ``~/.cache/tyrebayes/jax``. An empty ``$TYREBAYES_JAX_CACHE``
    switches the cache off (returned as "").
    """
    default = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "tyrebayes" / "jax"
    return os.environ.get("TYREBAYES_JAX_CACHE", str(default))


def enable_compilation_cache(path: str | None = None) -> str:
    """Point JAX's persistent compilation cache at ``path`` (default :func:`default_cache_dir`).

    Every compiled program is kept, however quick its compilation or small. Returns the folder
    in use, or "" when the cache is off or the folder cannot be made (a read-only home: run
    without it).
    """
    import jax

    path = default_cache_dir() if path is None else path
    if not path:
        return ""
    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError:
        return ""
    point_compilation_cache(path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    return path


def point_compilation_cache(path: str | None) -> None:
    """Point JAX's persistent compilation cache at ``path`` (``None``: off), effective at once.

    JAX opens its cache at the first compilation and keeps that folder for the process whatever
    the configuration says afterwards; resetting it makes the next compilation read the
    configuration again, so that switching the cache off (or moving it) really does.
    """
    import jax
    from jax.experimental.compilation_cache import compilation_cache

    jax.config.update("jax_compilation_cache_dir", path)
    compilation_cache.reset_cache()
