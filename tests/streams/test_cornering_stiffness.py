"""The per-axle cornering stiffness: its checks and the type prior."""

import numpy as np
import pytest

from tyrebayes.streams.cornering_stiffness import TYPE_PRIOR_CORNERING, CorneringStiffness


def test_cornering_stiffness_refuses_a_stiffness_that_is_not_positive():
    with pytest.raises(ValueError, match="front_per_rad: expected > 0"):
        CorneringStiffness(0.0, 20.0, 0.1)
    with pytest.raises(ValueError, match="log_sd: expected >= 0"):
        CorneringStiffness(16.0, 20.0, -0.1)
    assert TYPE_PRIOR_CORNERING.source == "type_prior"
    np.testing.assert_array_equal(TYPE_PRIOR_CORNERING.per_axle, [16.5, 16.5])
