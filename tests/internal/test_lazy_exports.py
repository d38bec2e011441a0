"""A subpackage's lazy public names: imported on first use, stored, unknown names refused."""

import sys

import pytest

from tyrebayes.internal.lazy_exports import lazy_exports


def test_a_name_is_imported_once_and_then_found_in_the_namespace():
    namespace: dict = {}
    getattr_, dir_ = lazy_exports("json", {"JSONDecoder": ".decoder"}, namespace)
    assert dir_() == ["JSONDecoder"] and namespace == {}
    decoder = getattr_("JSONDecoder")
    assert namespace["JSONDecoder"] is decoder is sys.modules["json.decoder"].JSONDecoder


def test_an_unknown_name_is_an_attribute_error_naming_the_package():
    getattr_, _ = lazy_exports("json", {}, {})
    with pytest.raises(AttributeError, match="module 'json' has no attribute 'loadz'"):
        getattr_("loadz")
