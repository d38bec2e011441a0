"""Scalar posterior summaries: :class:`PosteriorSummary` and its dict, the JSON contract."""

from __future__ import annotations

import dataclasses
import json
import math

import arviz_stats as azs
import numpy as np
import pytest

from tyrebayes._io import to_jsonable
from tyrebayes.inference.summary import PosteriorSummary, summarize


def test_draws_summarised_as_the_json_contract():
    draws = np.random.default_rng(1).gamma(4.0, 10.0, size=(4, 500))
    draws[0, :3] = [np.nan, np.inf, -np.inf]  # left out
    finite = draws[np.isfinite(draws)]
    lo, hi = np.asarray(azs.hdi(finite, prob=0.9))
    s = summarize(draws)
    assert s == PosteriorSummary(
        float(finite.mean()), float(finite.std(ddof=1)), float(lo), float(hi), 0.9
    )
    d = s.to_dict()
    assert list(d) == ["mean", "sd", "hdi_90"]
    assert d == {"mean": s.mean, "sd": s.sd, "hdi_90": [s.hdi_low, s.hdi_high]}
    assert all(type(v) is float for v in (d["mean"], d["sd"], *d["hdi_90"]))
    assert json.loads(json.dumps(to_jsonable(d))) == d
    assert s.hdi_low < s.mean < s.hdi_high


def test_interval_key_follows_its_probability():
    draws = np.random.default_rng(2).normal(size=2000)
    s = summarize(draws, hdi_prob=0.5)
    assert s.hdi_key == "hdi_50" and list(s.to_dict()) == ["mean", "sd", "hdi_50"]
    assert s.hdi_high - s.hdi_low < summarize(draws).hdi_high - summarize(draws).hdi_low


def test_degenerate_draws():
    empty = summarize([np.nan, np.inf])
    assert all(math.isnan(v) for v in (empty.mean, empty.sd, empty.hdi_low, empty.hdi_high))
    assert to_jsonable(empty.to_dict()) == {"mean": None, "sd": None, "hdi_90": [None, None]}
    constant = summarize(np.full(10, 3.5))
    assert constant.to_dict() == {"mean": 3.5, "sd": 0.0, "hdi_90": [3.5, 3.5]}
    two = summarize([1.0, 3.0])  # too few for an interval; the population sd
    assert (two.mean, two.sd) == (2.0, 1.0)
    assert math.isnan(two.hdi_low) and math.isnan(two.hdi_high)


def test_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        summarize([1.0, 2.0, 3.0]).mean = 0.0
