"""Windows into steps: order, blocks within a step, padding, bad input."""

import numpy as np
import pytest

from tyrebayes import BadInputError
from tyrebayes.inference.online import pad_steps, window_blocks

from ._synthetic import linear_windows


def test_steps_hold_whole_blocks_in_time_order():
    w = linear_windows(0, 95.0)
    order = np.random.default_rng(0).permutation(w["time_s"].size)
    shuffled = {k: v[order] for k, v in w.items()}
    blocks = window_blocks(shuffled, "dry", width=121)
    assert blocks.n_blocks == 4  # 0-30, 30-60, 60-90, 90-95 s
    np.testing.assert_allclose(np.asarray(blocks.time_s), [30.0, 60.0, 90.0, 120.0])
    first = np.asarray(blocks.slip[0])[np.asarray(blocks.mask[0])]
    np.testing.assert_allclose(first, w["slip"][:120])
    assert set(np.asarray(blocks.block_index[0])[np.asarray(blocks.mask[0])]) == set(range(6))
    padded = pad_steps(blocks, 6)
    assert padded.n_blocks == 6 and not bool(padded.mask[4:].any())
    assert float(padded.time_s[-1]) == 120.0


def test_bad_input_is_one_line():
    w = linear_windows(0, 40.0)
    with pytest.raises(BadInputError, match="at most 10 windows per step"):
        window_blocks(w, "dry", width=10)
    with pytest.raises(BadInputError, match="surface"):
        window_blocks(w, "mud")
    with pytest.raises(ValueError, match="whole multiple"):
        window_blocks(w, "dry", step_s=7.0)
