"""A jitted function's traced program kept on disk, so that a new process need not trace it again.

JAX's persistent compilation cache (:mod:`.jax_cache`) spares a new process the compilation of
a program it has compiled before, but not the Python tracing that comes first: seconds of
every fleet worker's first fit of a data shape and of every ``fit-tyre`` (a new process's first
fast fit of a one-hour drive: 7.8 s with the compiled programs alone, 2.7 s with the traced
ones and the layout kept too; ``benchmarks/results/stored_program.json``).
:func:`stored_program` keeps the traced program itself, exported as StableHLO
(:mod:`jax.export`), in a folder beside that cache: a process that finds it deserialises it
(milliseconds) and calls it, and the compilation cache then finds its compiled form as for
any program.

The file's name hashes the caller's key (what makes the program: model, data shape, settings),
the structure of the arguments, the versions of JAX and jaxlib and the package's own source
(:func:`source_fingerprint`: a program traced from other code is never read). Anything that
does not match, cannot be read or cannot be written means the jitted function is called as it
is: the store saves time, it never changes a result (the exported program is the one
``jax.jit`` would compile; a test checks that the results are equal).
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable
from pathlib import Path

import jax
import numpy as np

from .._io import atomic_write_bytes
from .heap import clear_staging_caches

_FOLDER = "tyrebayes-programs"


@functools.cache
def source_fingerprint() -> str:
    """A hash of this package's Python source and of the JAX and jaxlib versions.

    What is kept on disk from a traced model (a program, a layout's medians) depends on the code
    that traced it: any change to the package's source makes a new fingerprint.
    """
    import jaxlib

    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256(f"{jax.__version__} {jaxlib.__version__}".encode())
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def kept_file(folder: str, key: tuple, suffix: str) -> Path | None:
    """Where a file made from ``key`` by this package's code is kept beside JAX's compilation
    cache (``None`` when that cache is off): its name hashes ``key``, :func:`source_fingerprint`
    and the JAX backend."""
    cache = jax.config.jax_compilation_cache_dir
    if not cache:
        return None
    text = repr((key, source_fingerprint(), jax.default_backend()))
    return Path(cache) / folder / f"{hashlib.sha256(text.encode()).hexdigest()[:40]}{suffix}"


def stored_program(function: Callable, key: tuple) -> Callable:
    """``function`` (jitted), with its traced program kept on disk per ``key`` (module docstring).

    Parameters
    ----------
    function : callable
        A ``jax.jit``-ed function of arrays (pytrees of arrays) returning arrays in tuples,
        lists and dicts (no custom pytree nodes: they do not serialise).
    key : tuple
        What, beside the arguments' shapes and types, determines the traced program (hashable,
        with a stable ``repr``).

    Returns
    -------
    callable
        Called like ``function``, it returns the same values as NumPy arrays (in the same
        tuples, lists and dicts). The program is exported at the first call (where no file
        holds it) or read from its file, once per process and argument structure.
    """
    loaded: dict[str, Callable] = {}

    def call(*args):
        leaves, treedef = jax.tree.flatten(args)
        # As NumPy arrays (on the CPU a view, no copy): an argument committed to a device (a
        # result of an earlier call) against one that is not (made from NumPy) would make the
        # exported program's jitted call trace and compile again; and results committed to one
        # device would not mix with arrays spread over several (NUTS's chains).
        leaves = [np.asarray(leaf) for leaf in leaves]
        structure = str(treedef) + repr([(leaf.shape, str(leaf.dtype)) for leaf in leaves])
        program = loaded.get(structure)
        if program is None:
            # Its compilation, if it needs one, is the process's peak: the staging caches of
            # the programs compiled before are not needed for it (:mod:`.heap`).
            clear_staging_caches()
            program = _load_or_export(function, key, structure, treedef, leaves)
            loaded[structure] = program
        # The exported program's results come committed to one device; as NumPy arrays (on the
        # CPU a view) they mix, like a jitted function's, with arrays spread over several.
        return jax.tree.map(np.asarray, program(*leaves))

    return call


def _load_or_export(function, key, structure, treedef, leaves) -> Callable:
    """The program for these arguments as a function of their leaves."""

    def of_leaves(*values):
        return function(*jax.tree.unflatten(treedef, values))

    path = kept_file(_FOLDER, (key, structure), ".jaxexport")
    if path is None:
        return of_leaves
    try:
        from jax import export
    except ImportError:  # a JAX without jax.export
        return of_leaves
    exported = _read(export, path, leaves)
    if exported is None:
        try:
            exported = export.export(jax.jit(of_leaves))(*leaves)
        except Exception:  # noqa: BLE001 -- a program export cannot hold: trace as usual
            return of_leaves
        try:
            atomic_write_bytes(path, bytes(exported.serialize()))
        except Exception:  # noqa: BLE001 -- flatbuffers missing, a read-only folder: this
            # process still calls the exported program; the next one exports it again
            pass
    # Jitted once here: ``Exported.call`` builds a new function at every call, which would
    # compile (or load) the program again each time.
    return jax.jit(exported.call)


def _read(export, path: Path, leaves):
    """The exported program at ``path`` if it takes these leaves, else None."""
    try:
        exported = export.deserialize(bytearray(path.read_bytes()))
    except Exception:  # noqa: BLE001 -- no file, or one that is not what it claims
        return None
    expected = [(tuple(a.shape), str(a.dtype)) for a in exported.in_avals]
    if expected != [(tuple(leaf.shape), str(leaf.dtype)) for leaf in leaves]:
        return None
    return exported
