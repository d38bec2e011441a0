"""The benchmarks: scripts that measure speed, accuracy and calibration (``docs/benchmarks.md``).

A benchmark uses the package as a user does, through its public API:

* the names of ``tyrebayes`` itself (``tyrebayes.__all__``, listed in ``tyrebayes/__init__.pyi``):
  ``from tyrebayes import fit_tyre, load_vehicle``;
* the public namespaces of its subpackages: the names a subpackage's ``__init__.py`` lists in
  ``__all__`` (``tyrebayes.simulate``, the simulators with known truth; ``tyrebayes.physics``) or
  re-exports as ``from .module import name as name`` (``tyrebayes.streams``,
  ``tyrebayes.streams.can``, ``tyrebayes.inference`` and its ``online``, ``lateral``, ``wear``,
  ``fleet`` and ``vmax``, ``tyrebayes.criticism``, ``tyrebayes.batch``), and those subpackages
  themselves: ``from tyrebayes.simulate import simulate_drive``;
* the command line's entry point, ``tyrebayes.cli.main`` (the ``tyrebayes`` console script).

Never a module below a subpackage (``tyrebayes.simulate.drive``, ``tyrebayes.batch.settings``),
a ``_``-prefixed module or name (``tyrebayes._domain``, ``_windows_and_summary``), nor
``tyrebayes.internal``. The few internal steps, constants and modules a benchmark uses on purpose
(it times a stage's step, patches the force-density EM, reports an internal threshold) come from
:mod:`benchmarks._internal`, each with the reason; measurement children that run on another git
revision's package keep that revision's module paths and are named there.

Beside them, one module per concern: :mod:`benchmarks._data` loads every data set (the shared
``../shared/data`` and the data the package ships), :mod:`benchmarks._results` writes every result
(``write_result``, ``figure``, ``to_jsonable``, ``save_figure``). ``benchmarks/api_surface.py``
counts the benchmarks' imports of internal paths outside ``_internal.py`` (target 0).
"""
