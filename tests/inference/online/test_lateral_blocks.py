"""The online lateral estimator's blocks: braking samples left out, bad steps refused."""

import numpy as np
import pytest

from tyrebayes.inference.online.lateral_blocks import lateral_blocks

from ._cornering import observations


@pytest.fixture(scope="module")
def obs():
    return observations("mixed", 3)[0]


def test_braking_samples_are_left_out(obs):
    blocks = lateral_blocks(obs, max_longitudinal_mps2=0.3)
    ax = np.asarray(blocks.ax)
    mask = np.asarray(blocks.mask)
    assert not mask[np.abs(ax) > 0.3].any()
    assert (
        float(blocks.n_skipped.sum())
        == (
            np.asarray(obs.mask) & (np.abs(np.gradient(np.asarray(obs.speed), obs.dt_s)) > 0.3)
        ).sum()
    )
    assert not np.asarray(blocks.mask_kinematic)[:, [0, 1, -2, -1]].any()
    with pytest.raises(ValueError, match="step_s: expected a whole number"):
        lateral_blocks(obs, step_s=0.55)
