"""The estimator's command path: the curve model is named ``model``."""

import pytest

from tyrebayes.inference.online import online_estimate


def test_online_estimate_refuses_the_old_curve_keyword_naming_model():
    # The keyword is refused before the blocks are read.
    with pytest.raises(TypeError, match="online_estimate: keyword 'kind' is now 'model'"):
        online_estimate(None, kind="linear")
