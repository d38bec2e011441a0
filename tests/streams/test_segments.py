"""Regime labels and segment summaries."""

from __future__ import annotations

import numpy as np
import pytest

from tyrebayes.streams.segments import (
    SEGMENT_REGIMES,
    SegmentThresholds,
    label_samples,
    summarize_segments,
)


def test_label_priorities():
    valid = np.array([True, True, True, True, True, True, False])
    rho = np.array([0.0, 0.1, -0.1, 0.1, 0.1, np.nan, 0.1])
    slip = np.array([0.001, 0.01, -0.01, 0.2, 0.01, 0.0, 0.0])
    spin = np.zeros(7, bool)
    lat = np.array([0.0, 0.0, 0.0, 3.0, 3.0, 0.0, 0.0])
    got = [SEGMENT_REGIMES[i] for i in label_samples(valid, rho, slip, spin, lat)]
    assert got == [
        "free_rolling",
        "traction",
        "braking",
        "high_slip",
        "cornering",
        "invalid",
        "invalid",
    ]


def test_summary_counts_long_runs_and_all_seconds():
    label = np.array([1] * 10 + [2] * 3 + [1] * 60 + [0] * 5)
    seg = summarize_segments(np.arange(label.size) * 0.01, label, min_segment_s=0.5)
    assert seg["free_rolling"] == {"count": 1, "seconds": pytest.approx(0.7)}
    assert seg["traction"] == {"count": 0, "seconds": pytest.approx(0.03)}
    assert seg["cornering"] == {"count": 0, "seconds": 0.0}


def test_thresholds_are_checked():
    with pytest.raises(ValueError, match="SegmentThresholds.slip_high"):
        SegmentThresholds(slip_high=-0.1)
