"""tyrebayes: tyre parameters with honest uncertainty from the sensors every car already has.

The public API in task order, re-exported from the modules that define it:

1. read and validate streams (:mod:`tyrebayes.streams`), vehicles and measured data;
2. fit (:mod:`tyrebayes.inference`): every fitter returns a :class:`Fit` (or, per tyre, a
   :class:`TyreFit` wrapping one) with :class:`Diagnostics` under one policy;
3. predict from fits;
4. decide (:mod:`tyrebayes.decisions`);
5. criticise (:mod:`tyrebayes.criticism`);
6. report (:mod:`tyrebayes.report`);
7. run a fleet of drive logs on dask.distributed (:mod:`tyrebayes.batch`).

Physics lives in :mod:`tyrebayes.physics`; simulated drives and fleets with known truth in
:mod:`tyrebayes.simulate` (not re-exported here: the library never needs them).

The names are listed in ``__init__.pyi`` (which type checkers read) and each is imported on first
use (PEP 562), so that ``import tyrebayes`` takes milliseconds: the command line has its signal
handling in place before JAX loads, and a Ctrl-C while it loads ends with one line.

Examples
--------
>>> import tyrebayes
>>> tyrebayes.__all__[:3]
['SURFACES', 'TYRE_TYPES', 'load_vehicle']
>>> tyrebayes.fit_tyre.__module__
'tyrebayes.inference.tyre.fit'
"""

import ast as _ast
import importlib as _importlib
import importlib.util as _importlib_util
import os as _os
import sys as _sys
from pathlib import Path as _Path

from .internal.lazy_exports import lazy_exports as _lazy_exports

__version__ = "0.2.0"

# Float64 before anything of the package makes an array. Slips are ~1e-3 with noise of ~1e-4,
# so a tyre fit in single precision could only end as not converged; the fitters refuse float32
# observations with a ValueError rather than return such a fit. A library that needs a precision
# sets it up itself instead of making every script repeat the line. It is JAX's process-wide
# switch: where JAX is loaded already it is set now; otherwise JAX reads it from the environment
# when it loads (an explicit JAX_ENABLE_X64 of the user's is kept, and the fitters then refuse
# float32 observations with a message that says so).
if "jax" in _sys.modules:
    _sys.modules["jax"].config.update("jax_enable_x64", True)
else:
    _os.environ.setdefault("JAX_ENABLE_X64", "1")


def _exports() -> dict[str, str]:
    """Public name → the module that defines it, in the stub's (task) order."""
    stub = _ast.parse(_Path(__file__).with_suffix(".pyi").read_text(encoding="utf-8"))
    return {
        alias.asname or alias.name: f"{__name__}.{node.module}"
        for node in stub.body
        if isinstance(node, _ast.ImportFrom)
        for alias in node.names
    }


_EXPORTS = _exports()

# The public names, in task order (the documentation's order too).
__all__ = list(_EXPORTS)


_lazy_getattr, __dir__ = _lazy_exports(__name__, _EXPORTS, globals())


def __getattr__(name: str) -> object:
    # A subpackage used as an attribute (``tyrebayes.streams``) after ``import tyrebayes``.
    if name not in _EXPORTS and _importlib_util.find_spec(f"{__name__}.{name}") is not None:
        return _importlib.import_module(f"{__name__}.{name}")
    return _lazy_getattr(name)
