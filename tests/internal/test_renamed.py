"""Renamed keywords: the old word raises a TypeError naming the new one and what it takes."""

import pytest

from tyrebayes.internal.renamed import renamed_keyword


@renamed_keyword("kind", "model", what="the tyre-curve model")
def _curve(model: str = "magic") -> str:
    return model


def test_the_new_keyword_and_positional_calls_pass_through():
    assert _curve(model="brush") == "brush" and _curve("linear") == "linear" and _curve() == "magic"


def test_the_old_keyword_names_the_new_one_and_what_it_takes():
    with pytest.raises(TypeError, match=r"_curve: keyword 'kind' is now 'model' \(the tyre-curve"):
        _curve(kind="brush")
