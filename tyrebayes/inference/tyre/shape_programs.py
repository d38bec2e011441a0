"""Forgetting the compiled programs of the data shapes a process has fitted, but not the rest.

A tyre fit compiles programs per data shape (padded windows, drives, surfaces: the refinement,
the Laplace draws, the predictive; NUTS's sampler) and programs shared by every shape of the
same drives and surfaces (the model's layout, the search on a subset of the windows:
:func:`~.map_starts.search_windows`). A fleet worker that moves to a new padded shape does not
need the old shape's programs again soon (it fits the sets in order of size), and they hold about
a hundred MB; the shared ones it needs at once, and loading the subset search alone costs more
than the rest of a new shape's programs (one-off: a new shape's fit took 1.9-2.4 CPU s after
:func:`drop_shape_programs`, 4.2-4.3 s after ``jax.clear_caches``, against about 1.2 s with its
programs kept).
"""

from __future__ import annotations

import gc


def drop_shape_programs() -> None:
    """Drop the per-shape programs of every tyre fit made in this process (module docstring).

    Their caches are emptied, then JAX's staging caches; a collection frees the jitted
    functions, whose compiled executables go with them (they sit in reference cycles), and the
    freed heap goes back to the system.
    """
    from ...internal.heap import clear_staging_caches, release_free_memory
    from .laplace import _laplace_core
    from .nuts import _nuts_runner
    from .predictive import _predictive_core

    for cache in (_laplace_core, _predictive_core, _nuts_runner):
        cache.cache_clear()
    clear_staging_caches()
    gc.collect()
    release_free_memory()


__all__ = ["drop_shape_programs"]
