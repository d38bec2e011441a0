"""The physics' public namespace (``tyrebayes.physics.__all__``), each name loaded on use."""

from __future__ import annotations

import subprocess
import sys

import pytest

import tyrebayes
import tyrebayes.physics as physics


def test_every_listed_name_resolves_and_matches_the_package_export():
    assert len(physics.__all__) == len(set(physics.__all__))
    for name in physics.__all__:
        value = getattr(physics, name)
        if name in tyrebayes.__all__:
            assert value is getattr(tyrebayes, name)
    from tyrebayes.physics.wear import TreadGeometry

    assert physics.TreadGeometry is TreadGeometry


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_model"):
        physics.no_such_model  # noqa: B018


def test_the_vehicle_module_loads_without_the_others():
    # Reading a vehicle file imports tyrebayes.physics.vehicle: the lane change and its JAX
    # programs must not come with it.
    code = (
        "import sys, tyrebayes.physics.vehicle; m = sys.modules; "
        "print('tyrebayes.physics.lanechange' in m, 'tyrebayes.physics.wear' in m)"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["False", "False"]
