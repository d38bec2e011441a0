"""The online lateral estimator: a simulated replay against the batch fit.

Every replay is 300 s (10 blocks of 30 s), so the tests share one compiled run.
"""

import numpy as np
import pytest

from tyrebayes.inference.lateral import fit_lateral
from tyrebayes.inference.online.lateral import online_lateral
from tyrebayes.inference.online.lateral_blocks import lateral_blocks

from ._cornering import observations

pytestmark = pytest.mark.early  # compiles the estimator (tens of seconds)


@pytest.fixture(scope="module")
def mixed():
    obs, truth = observations("mixed", 3)
    run = online_lateral(lateral_blocks(obs))
    return obs, truth, run.estimate, run.trajectory


def test_mixed_replay_is_ready_and_agrees_with_the_batch_fit(mixed):
    obs, truth, result, trajectory = mixed
    assert result.k_identified and result.split_identified
    online = result.to_dict()
    assert online["ready"] and online["reason"] == ""
    batch = fit_lateral(obs).to_dict()
    for key in ("c_y_front", "c_y_rear", "understeer_gradient"):
        assert set(online[key]) == {"mean", "sd", "hdi_90"}
        # Stated tolerance: within two batch sds of the batch mean (the benchmark's figure
        # counts one), and the truth inside the online 90 % interval.
        gap = abs(online[key]["mean"] - batch[key]["mean"]) / batch[key]["sd"]
        assert gap <= 2.0, (key, gap)
        lo, hi = online[key]["hdi_90"]
        assert lo <= getattr(truth, key) <= hi, key
    # The trajectory narrows: the last block's c_y sd below the first's.
    sd = np.asarray(trajectory.estimates()["c_y_front"]["sd"])
    assert trajectory.time_s.shape == (10,) and sd[-1] < sd[0]
