"""The process's heap: freed memory given back, and JAX's staging caches dropped.

A compilation is the peak of a process that fits once (``tyrebayes fit-tyre``): XLA's working
memory while it compiles comes on top of everything the process holds then. Two things held
then are not needed again: heap that glibc keeps after it was freed (:func:`release_free_memory`)
and JAX's staging caches of the programs compiled before, their traced and lowered forms, which
their compiled executables no longer need (:func:`clear_staging_caches`).
"""

from __future__ import annotations


def release_free_memory() -> None:
    """Give the memory the allocator holds but no object uses back to the system (glibc).

    A fleet worker's tasks free what they allocate, but glibc keeps freed heap below chunks
    still in use: after a tyre-set fit most of a worker's resident memory can be such free heap,
    and it counts towards the worker's limit and every later task's peak (the ``fleet_run``
    benchmark's result has the per-task peaks). No-op where there is no glibc.
    """
    import ctypes

    # No gc.collect() here: arrays go when their last reference does, and a full collection
    # walks every object of a worker that has traced fits. With one before and after each task
    # the full-size fleet_run benchmark spent 1.5 CPU s per drive-hour outside the drive
    # stage's steps, 0.1 s without.
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def clear_staging_caches() -> None:
    """Drop JAX's staging caches (traced jaxprs, lowered modules), keep the compiled programs.

    ``jax.clear_caches`` drops the compiled executables too, and a program called again must
    then be loaded or compiled again; the staging caches alone are only needed to trace a new
    program from the same functions, which tracing then redoes. Their clearing function is not
    public in JAX: where it is missing, nothing is cleared (memory, never a result, depends on
    it).

    Examples
    --------
    >>> import jax, jax.numpy as jnp
    >>> f = jax.jit(lambda x: 2 * x)
    >>> float(f(jnp.ones(())))
    2.0
    >>> clear_staging_caches()
    >>> float(f(jnp.ones(())))  # the compiled program is still there
    2.0
    """
    try:
        from jax._src import util
    except ImportError:
        return
    clear = getattr(util, "clear_all_caches", None)
    if clear is not None:
        clear()
    release_free_memory()


__all__ = ["clear_staging_caches", "release_free_memory"]
