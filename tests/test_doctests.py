"""Every example in the package's docstrings runs as written (doctest), in the default test run.

One test per module, under this suite's strict settings (tests/conftest.py: float64, rank
promotion raises, warnings are errors). An example that needs a fit of minutes or a file the
package does not ship says ``# doctest: +SKIP``.
"""

from __future__ import annotations

import doctest
import importlib
import io
import pkgutil

import pytest

import tyrebayes

#: Modules whose examples are known to fail, with the reason; each is an xfail that must start
#: failing to pass (strict), so that a fixed example leaves this list.
KNOWN_FAILING: dict[str, str] = {}

MODULES = sorted(
    info.name
    for info in pkgutil.walk_packages(tyrebayes.__path__, prefix="tyrebayes.")
    if not info.name.endswith("__main__")
)


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.xfail(reason=KNOWN_FAILING[n], strict=True))
        if n in KNOWN_FAILING
        else n
        for n in MODULES
    ],
)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    tests = doctest.DocTestFinder(exclude_empty=True).find(module, name)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    out = io.StringIO()
    for test in tests:
        runner.run(test, out=out.write)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, out.getvalue()
