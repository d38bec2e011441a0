"""The stream stage (read + validate + features) gives the same numbers as before its speed work.

The fixture in ``tests/streams/data/`` was written by ``make_pipeline_reference.py`` with the
pipeline as it was before the issue-23 optimisations: two 90 s drives (a simulated one with
jittered time stamps and dropped samples, a synthetic one on a uniform time base) and, for every
output array, a fingerprint. Agreement is to 1e-9 relative (floating-point reordering only).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.streams.data.make_pipeline_reference import INPUTS, pipeline_outputs, summarise

DATA = Path(__file__).resolve().parent / "data"
RTOL = 1e-9
# Outputs the pipeline gained after the reference was written: new quantities, not changed ones
# (each is checked by its own test; test_features.py for the load change).
ADDED_SINCE_REFERENCE = {"features.load_change_driven"}


def _close(a: float, b: float, scale: float) -> bool:
    return math.isclose(a, b, rel_tol=RTOL, abs_tol=RTOL * max(scale, 1e-300))


@pytest.mark.parametrize("name", sorted(INPUTS))
def test_pipeline_matches_reference(name):
    reference = json.loads((DATA / "pipeline_reference.json").read_text())[name]
    vehicle, file = INPUTS[name]
    current = summarise(pipeline_outputs(DATA / file, vehicle))
    assert sorted(set(current) - ADDED_SINCE_REFERENCE) == sorted(reference)
    for key, ref in reference.items():
        got = current[key]
        if "text" in ref:
            assert got == ref, key
            continue
        assert got["shape"] == ref["shape"], key
        assert got["finite"] == ref["finite"], key
        if ref["finite"] == 0:
            continue
        assert got["nan_pattern"] == ref["nan_pattern"], key
        scale = ref["abs_sum"]
        for field in ("sum", "abs_sum", "weighted_sum"):
            assert _close(got[field], ref[field], scale), (key, field, got[field], ref[field])
        picks_scale = max((abs(v) for v in ref["picks"] if v is not None), default=1.0)
        for g, r in zip(got["picks"], ref["picks"], strict=True):
            assert (g is None) == (r is None), key
            if r is not None:
                assert _close(g, r, picks_scale), (key, g, r)


def test_fingerprint_detects_a_change():
    x = np.linspace(0.0, 1.0, 1000)
    y = x.copy()
    y[500] += 1e-6
    a, b = summarise({"x": x})["x"], summarise({"x": y})["x"]
    assert not _close(a["weighted_sum"], b["weighted_sum"], a["abs_sum"])
