"""The online lateral estimator's blocks: braking samples counted, bad steps refused, padding
that changes nothing."""

import numpy as np
import pytest

from tyrebayes.inference.online.lateral_blocks import lateral_blocks

from ._cornering import observations


@pytest.fixture(scope="module")
def obs():
    return observations("mixed", 3)[0]


def test_braking_samples_are_left_out(obs):
    """The observations' braking samples (``longitudinal``) stay out and are counted per
    block."""
    blocks = lateral_blocks(obs)
    longitudinal = np.asarray(obs.longitudinal)
    assert float(blocks.n_skipped.sum()) == longitudinal.sum()
    n = longitudinal.size
    assert not np.asarray(blocks.mask).reshape(-1)[:n][longitudinal].any()
    assert not np.asarray(blocks.mask_kinematic)[:, [0, 1, -2, -1]].any()
    with pytest.raises(ValueError, match="step_s: expected a whole number"):
        lateral_blocks(obs, step_s=0.55)


def test_padding_blocks_change_nothing(obs):
    """Empty blocks after the record (a shared compiled length) pass no time: the estimate is
    the unpadded one's."""
    import jax

    from tyrebayes.inference.online.lateral import online_lateral

    jax.config.update("jax_enable_x64", True)
    plain = lateral_blocks(obs)
    padded = lateral_blocks(obs, n_blocks=plain.n_blocks + 6)
    assert float(padded.time_s[-1]) == float(plain.time_s[-1])
    a, b = online_lateral(plain).estimate, online_lateral(padded).estimate
    # Stated tolerance: an empty block may take one more Gauss-Newton step towards the same
    # mode (its steps end below 0.01 posterior sd), nothing more.
    sd = np.sqrt(np.diag(np.asarray(a.cov)))
    assert np.all(np.abs(np.asarray(a.mean) - np.asarray(b.mean)) < 0.01 * sd)
    np.testing.assert_allclose(np.asarray(a.cov), np.asarray(b.cov), rtol=1e-3)
