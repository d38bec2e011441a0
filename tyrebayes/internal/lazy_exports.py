"""A subpackage's public names, each imported from its module on first use (PEP 562)."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping


def lazy_exports(
    package: str, exports: Mapping[str, str], namespace: dict
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of ``package`` for the names ``exports`` lists.

    Parameters
    ----------
    package : str
        The package's ``__name__`` (relative module names are resolved against it).
    exports : Mapping of str to str
        Public name → the module that holds it (``".drive"``, or an absolute name).
    namespace : dict
        The package's ``globals()``: a name, once imported, is stored there, so that later
        look-ups skip ``__getattr__``.

    Examples
    --------
    >>> namespace = {}
    >>> getattr_, dir_ = lazy_exports("json", {"JSONDecoder": ".decoder"}, namespace)
    >>> getattr_("JSONDecoder").__name__, "JSONDecoder" in namespace, dir_()
    ('JSONDecoder', True, ['JSONDecoder'])
    >>> getattr_("nothing")
    Traceback (most recent call last):
    ...
    AttributeError: module 'json' has no attribute 'nothing'
    """

    def __getattr__(name: str) -> object:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *exports})

    return __getattr__, __dir__
