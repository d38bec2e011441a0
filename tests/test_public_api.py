"""The public API (``tyrebayes.__all__``): every name documented in numpydoc, and how many show an
example.

The examples themselves run as doctests in ``tests/test_doctests.py``.
"""

from __future__ import annotations

import inspect
import os
import re
import subprocess
import sys
import types

import tyrebayes as tb

#: numpydoc's section names (https://numpydoc.readthedocs.io/en/latest/format.html).
NUMPYDOC_SECTIONS = {
    "Parameters",
    "Attributes",
    "Methods",
    "Returns",
    "Yields",
    "Receives",
    "Other Parameters",
    "Raises",
    "Warns",
    "Warnings",
    "See Also",
    "Notes",
    "References",
    "Examples",
}

#: Public callables that take arguments but whose docstring has no Parameters (functions) or
#: Attributes/Parameters (classes) section yet (issue 58). The list may only shrink: a name that
#: gains its section must leave it, and a new public name must come with its section.
WITHOUT_ARGUMENT_SECTION = {
    "load_vehicle",
    "load_tyre_type_priors",
    "observations_from_stream",
    "with_pointwise",
    "build_wear_data",
    "drive_history",
    "tread_readings",
    "vmax_draws",
    "predict_wear_volume",
    "critical_speed",
    "compensate_stiffness",
    "relative_wear",
    "cost_threshold",
    "dask_client",
}

#: Fewest public callables with an Examples section; raise it as examples are added. The issue's
#: target is 90 %.
EXAMPLES_FLOOR = 97

_SECTION = re.compile(r"^(?P<name>[A-Z][A-Za-z ]*)\n(?P<rule>-+)$", re.M)


def _callables() -> dict[str, object]:
    return {
        name: getattr(tb, name)
        for name in tb.__all__
        if callable(getattr(tb, name)) and not isinstance(getattr(tb, name), types.ModuleType)
    }


def _sections(doc: str) -> list[str]:
    return [m["name"] for m in _SECTION.finditer(doc)]


def _takes_arguments(obj) -> bool:
    try:
        parameters = inspect.signature(obj).parameters
    except (TypeError, ValueError):
        return False
    return any(p not in ("self", "cls") for p in parameters)


def test_all_lists_every_public_name_once():
    for name in tb.__all__:  # each loads on first use; every one must resolve
        getattr(tb, name)
    public = {
        name
        for name, value in vars(tb).items()
        if not name.startswith("_") and not isinstance(value, types.ModuleType)
    }
    assert len(tb.__all__) == len(set(tb.__all__))
    assert set(tb.__all__) == public


def test_every_public_callable_has_a_numpydoc_docstring():
    problems = []
    for name, obj in _callables().items():
        doc = inspect.getdoc(obj) or ""
        if not doc.strip():
            problems.append(f"{name}: no docstring")
            continue
        lines = doc.splitlines()
        if len(lines) > 1 and lines[1].strip():
            problems.append(f"{name}: the summary is not one line followed by a blank line")
        for m in _SECTION.finditer(doc):
            if m["name"] not in NUMPYDOC_SECTIONS:
                problems.append(f"{name}: section {m['name']!r} is not numpydoc's")
            elif len(m["rule"]) != len(m["name"]):
                problems.append(f"{name}: the rule under {m['name']!r} is not as long as it")
        wanted = {"Parameters"} if inspect.isfunction(obj) else {"Attributes", "Parameters"}
        has_section = bool(wanted & set(_sections(doc)))
        if _takes_arguments(obj) and not has_section and name not in WITHOUT_ARGUMENT_SECTION:
            problems.append(f"{name}: takes arguments but has no {' or '.join(sorted(wanted))}")
        if has_section and name in WITHOUT_ARGUMENT_SECTION:
            problems.append(f"{name}: documents its arguments now; drop it from the list")
    assert problems == []


def test_examples_in_public_docstrings(capsys):
    names = _callables()
    with_examples = sorted(
        n for n, o in names.items() if "Examples" in _sections(inspect.getdoc(o) or "")
    )
    with capsys.disabled():
        print(
            f"\npublic callables with an Examples section: {len(with_examples)} of {len(names)} "
            f"({100 * len(with_examples) / len(names):.0f} %)"
        )
    assert len(with_examples) >= EXAMPLES_FLOOR


def test_import_loads_nothing_heavy_and_sets_float64():
    # A fresh interpreter: ``import tyrebayes`` (and the command line's module) must not load
    # JAX, so the CLI's signal handling is in place before the slow imports; and the arrays a
    # user makes after it are float64, as the fitters need.
    code = (
        "import sys, tyrebayes, tyrebayes.cli; loaded = 'jax' in sys.modules; "
        "import jax.numpy as jnp; print(loaded, jnp.zeros(1).dtype, tyrebayes.fit_tyre.__name__)"
    )
    env = {k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["False", "float64", "fit_tyre"]


def test_unknown_attribute_is_an_attribute_error():
    try:
        tb.no_such_name  # noqa: B018
    except AttributeError as err:
        assert "no_such_name" in str(err)
    else:
        raise AssertionError("expected AttributeError")
