"""Order statistics equal NumPy's to the last bit (they replace np.median / np.quantile)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tyrebayes.streams.order_stats import (
    median,
    median_at_most,
    nanmedian,
    nanmedian_columns,
    quantile,
)


def _arrays(rng):
    """Long arrays of the kinds the stream stage sees: continuous, quantised, clock steps."""
    n = 5001
    steps = np.diff(np.cumsum(np.full(n + 1, 0.01)))  # a uniform clock: a few distinct values
    jitter = np.diff(np.cumsum(0.01 + 0.003 * rng.uniform(-1, 1, n + 1)))
    quantised_walk = np.cumsum(np.round(rng.normal(0, 0.3, n + 2)) * 0.1)  # a step in 3 samples
    second_differences = quantised_walk[2:] - 2 * quantised_walk[1:-1] + quantised_walk[:-2]
    mostly_zero = np.where(rng.uniform(size=n) < 0.45, 0.0, rng.exponential(size=n))
    return {
        "normal": rng.normal(size=n),
        "tied_quantised_differences": np.abs(second_differences),
        "tied_below_the_median": mostly_zero,
        "tied_above_the_median": -mostly_zero,
        # Rank n/2 − 1 is the last 0, rank n/2 the smallest value above it.
        "tie_ends_at_the_median": rng.permutation(
            np.concatenate([np.zeros(2500), rng.exponential(size=2500)])
        ),
        "normal_even": rng.normal(size=n + 1),
        "quantised": np.round(rng.normal(size=n), 2),
        "few_values": rng.integers(0, 5, n).astype(float),
        "clock_steps": steps,
        "jittered_steps": jitter,
        "short": rng.normal(size=7),
    }


@pytest.mark.parametrize("case", sorted(_arrays(np.random.default_rng(0))))
def test_equal_to_numpy(case):
    x = _arrays(np.random.default_rng(0))[case]
    before = x.copy()
    assert median(x) == float(np.median(x))
    for q in (0.0, 0.25, 0.5, 0.95, 0.99, 1.0, 0.3141):
        assert quantile(x, q) == float(np.quantile(x, q)), q
    limit = float(np.quantile(x, 0.6))
    assert median_at_most(x, limit) == float(np.median(x[x <= limit]))
    np.testing.assert_array_equal(x, before)  # inputs are not modified
    # Reordering a temporary in place gives the same numbers.
    assert median(x.copy(), overwrite_input=True) == float(np.median(x))
    assert quantile(x.copy(), 0.25, overwrite_input=True) == float(np.quantile(x, 0.25))
    assert median_at_most(x.copy(), limit, overwrite_input=True) == float(np.median(x[x <= limit]))


def test_nan_handling_as_numpy():
    x = np.random.default_rng(1).normal(size=4000)
    x[[5, 77, 3000]] = np.nan
    assert np.isnan(median(x)) and np.isnan(quantile(x, 0.25))
    assert nanmedian(x) == float(np.nanmedian(x))
    table = np.column_stack([x, x[::-1] * 2.0])
    np.testing.assert_array_equal(nanmedian_columns(table), np.nanmedian(table, axis=0))
    assert np.isnan(nanmedian(np.full(3000, np.nan)))  # all NaN: NaN, as numpy (no warning)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    st.integers(2048, 6000),
    st.floats(0.0, 0.95),
    st.sampled_from([0.0, -1.5, 2.0]),
    st.integers(0, 2**32 - 1),
)
def test_ties_anywhere_equal_numpy(n, share, tied, seed):
    """One value holding any share of an array, the rest continuous on both sides of it: every
    rank (ties or not) as NumPy gives it."""
    rng = np.random.default_rng(seed)
    x = np.where(rng.uniform(size=n) < share, tied, rng.normal(size=n))
    assert median(x) == float(np.median(x))
    for q in (0.1, 0.25, 0.5, 0.75, 0.9):
        assert quantile(x, q) == float(np.quantile(x, q)), q
