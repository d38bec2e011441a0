"""The simulators' public namespace (``tyrebayes.simulate.__all__``), each name loaded on use."""

from __future__ import annotations

import subprocess
import sys

import pytest

import tyrebayes.simulate as simulate


def test_every_listed_name_resolves_to_its_module_object():
    assert len(simulate.__all__) == len(set(simulate.__all__))
    for name in simulate.__all__:
        value = getattr(simulate, name)
        if callable(value):
            assert value.__name__ == name
    from tyrebayes.simulate.drive import simulate_drive

    assert simulate.simulate_drive is simulate_drive
    assert set(simulate.__all__) <= set(dir(simulate))


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_simulator"):
        simulate.no_such_simulator  # noqa: B018


def test_a_name_loads_its_own_module_only():
    code = (
        "import sys; from tyrebayes.simulate import THESIS_AGED_TYRE_EFFECT; "
        "print('tyrebayes.simulate.fleet' in sys.modules, 'tyrebayes.simulate.wear' in sys.modules)"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["True", "False"]
