"""Windows into steps: order, blocks within a step, padding, bad input."""

import numpy as np
import pytest

from tyrebayes import BadInputError
from tyrebayes.inference.online import pad_steps, window_blocks

from ._synthetic import linear_windows


def test_steps_hold_whole_blocks_in_time_order():
    w = linear_windows(0, 95.0)
    order = np.random.default_rng(0).permutation(len(w))
    shuffled = w.select(order)
    blocks = window_blocks(shuffled, "dry", width=121)
    assert blocks.n_blocks == 4  # 0-30, 30-60, 60-90, 90-95 s
    np.testing.assert_allclose(np.asarray(blocks.time_s), [30.0, 60.0, 90.0, 120.0])
    np.testing.assert_allclose(np.asarray(blocks.span_s), 30.0)
    first = np.asarray(blocks.slip[0])[np.asarray(blocks.mask[0])]
    np.testing.assert_allclose(first, w.slip[:120])
    assert set(np.asarray(blocks.block_index[0])[np.asarray(blocks.mask[0])]) == set(range(6))
    padded = pad_steps(blocks, 6)
    assert padded.n_blocks == 6 and not bool(padded.mask[4:].any())
    np.testing.assert_allclose(np.asarray(padded.span_s), [30, 30, 30, 30, 0, 0])
    assert float(padded.time_s[-1]) == 120.0


def test_sparse_blocks_pack_into_steps_up_to_their_width_and_span():
    # One 5 s block of windows (20) every 15 s: a clock-cut 30 s step would hold 40.
    w = linear_windows(0, 300.0)
    w = w.select((w.time_s // 5.0) % 3 == 0)
    clock = window_blocks(w, "dry", width=60)
    packed = window_blocks(w, "dry", width=60, max_step_s=60.0)
    assert clock.n_blocks == 10 and packed.n_blocks == 7
    counts = np.asarray(packed.mask).sum(axis=1)
    # 0-30 s taken whatever the width (2 blocks), then one more block fits 60 windows.
    np.testing.assert_array_equal(counts, [60, 60, 60, 60, 60, 60, 40])
    # A step starts on the 30 s clock, or where the last one ended if later, and ends 30 s on
    # or with its last block.
    np.testing.assert_allclose(np.asarray(packed.time_s), [35, 80, 125, 170, 215, 260, 300])
    np.testing.assert_allclose(np.asarray(packed.span_s), [35, 45, 35, 45, 35, 45, 30])
    starts = np.asarray(packed.time_s) - np.asarray(packed.span_s)
    assert np.all(np.diff(starts) >= 30.0) and np.all(starts[1:] >= np.asarray(packed.time_s)[:-1])
    # Blocks numbered within their step over those with windows.
    for step in range(packed.n_blocks):
        index = np.asarray(packed.block_index[step])[np.asarray(packed.mask[step])]
        assert sorted(set(index)) == list(range(len(set(index))))
    # Same windows, same order, nothing lost or duplicated.
    np.testing.assert_allclose(
        np.sort(np.asarray(packed.slip)[np.asarray(packed.mask)]), np.sort(w.slip)
    )
    # A wider width packs more, up to the span: 0-60 s holds 4 blocks.
    wide = window_blocks(w, "dry", width=200, max_step_s=60.0)
    assert int(np.asarray(wide.mask).sum(axis=1)[0]) == 80
    # A step never spans two drives.
    w2 = w.replace(drive=(w.time_s > 100.0).astype(int))
    split = window_blocks(w2, "dry", width=60, max_step_s=60.0)
    assert int(np.asarray(split.drive_start).sum()) == 2


def test_bad_input_is_one_line():
    w = linear_windows(0, 40.0)
    with pytest.raises(BadInputError, match="at most 10 windows per step"):
        window_blocks(w, "dry", width=10)
    with pytest.raises(BadInputError, match="surface"):
        window_blocks(w, "mud")
    with pytest.raises(ValueError, match="whole multiple"):
        window_blocks(w, "dry", step_s=7.0)
    with pytest.raises(BadInputError, match="max_step_s"):
        window_blocks(w, "dry", max_step_s=25.0)
