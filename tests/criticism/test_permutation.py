"""Permutation scan: strata respected, p-values uniform under the null, power on a clear effect."""

from __future__ import annotations

import numpy as np
from scipy import stats

from tyrebayes.criticism.permutation import permutation_pvalue, stratified_permutations


def test_permutations_stay_within_strata():
    strata = np.array([0, 1, 0, 1, 1, 2, 0])
    idx = stratified_permutations(strata, 50, np.random.default_rng(3))
    assert idx.shape == (50, 7)
    assert np.all(strata[idx] == strata[None, :])
    assert np.all(np.sort(idx, axis=1) == np.arange(7))
    assert len({tuple(r) for r in idx}) > 10  # not the identity over and over


def test_pvalues_are_uniform_under_the_null_with_heavy_tails():
    """300 null data sets (n = 30, Student-t(3) noise, intercept + slope baseline, two groups
    with different scales permuted within group): the share of p <= 0.05 must lie in
    [0.02, 0.09] (binomial 99 % range at 0.05 for 300 is 0.025-0.085) and a Kolmogorov-Smirnov
    test against U(0, 1) must not reject at 0.001 (p-values on a grid of 1/200: ties allowed)."""
    rng = np.random.default_rng(0)
    n = 30
    group = np.arange(n) % 2
    p_values = []
    for _ in range(300):
        x0 = np.column_stack([np.ones(n), rng.normal(size=n)])
        y = x0 @ np.array([1.0, 0.5]) + (1.0 + 2.0 * group) * rng.standard_t(3, size=n)
        perms = stratified_permutations(group, 199, rng)
        p_values.append(permutation_pvalue(y, x0, rng.normal(size=(n, 1)), perms)[0])
    p = np.array(p_values)
    assert 0.02 <= np.mean(p <= 0.05) <= 0.09
    assert stats.kstest(p, "uniform").pvalue > 1e-3


def test_clear_effect_reaches_the_smallest_pvalue_and_rank_deficient_candidate_is_one():
    rng = np.random.default_rng(1)
    n = 40
    x = rng.normal(size=n)
    y = 1.0 * x + 0.3 * rng.normal(size=n)
    perms = stratified_permutations(np.zeros(n, int), 999, rng)
    p, share = permutation_pvalue(y, np.ones((n, 1)), x[:, None], perms)
    assert p == 1.0 / 1000.0
    assert 0.8 < share < 1.0
    # A candidate inside the baseline's span adds nothing.
    assert permutation_pvalue(y, np.ones((n, 1)), np.ones((n, 1)), perms) == (1.0, 0.0)
