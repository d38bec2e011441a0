"""The shared value checks: concrete values raise a one-line ValueError, traced ones pass."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.internal.validation import (
    check_in_range,
    check_nonnegative,
    check_positive,
    check_positive_or_inf,
)

CASES = [
    (check_positive, [1.0, 2.0], [1.0, 0.0]),
    (check_positive, [3.0], [np.inf]),
    (check_nonnegative, [0.0, 2.0], [-1e-9]),
    (check_positive_or_inf, [1.0, np.inf], [0.0, np.inf]),
    (check_positive_or_inf, [5.0], [np.nan]),
]


@pytest.mark.parametrize(("check", "good", "bad"), CASES)
def test_a_bad_value_names_its_owner_and_field(check, good, bad):
    check("Owner", "field", np.asarray(good))
    with pytest.raises(ValueError, match=r"Owner\.field: expected") as err:
        check("Owner", "field", np.asarray(bad))
    assert "\n" not in str(err.value)


def test_range_and_traced_values():
    check_in_range("Owner", "share", 0.5, 0.0, 1.0)
    with pytest.raises(ValueError, match=r"\[0.0, 1.0\]"):
        check_in_range("Owner", "share", 1.5, 0.0, 1.0)
    # Inside a trace the value is unknown: the check passes it.
    jax.jit(lambda x: (check_positive_or_inf("Owner", "field", x), x)[1])(jnp.zeros(2))
