"""The lengths a lateral fit pads a drive to, and the padding itself."""

import dataclasses

import numpy as np

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import cornering_observations, search
from tyrebayes.simulate.cornering import simulate_cornering

VEHICLE = load_vehicle("compact_fwd")
DURATION_S = 240.0


def test_observations_are_padded_outside_both_masks():
    frame, _ = simulate_cornering(VEHICLE, manoeuvre="mixed", duration_s=DURATION_S, seed=11)
    whole = cornering_observations(frame, VEHICLE)
    obs = dataclasses.replace(
        whole, **{name: getattr(whole, name)[:2390] for name in search._SERIES}
    )
    padded = search._padded(obs)
    n = obs.speed.shape[0]
    assert padded.speed.shape[0] == search.padded_length(n) > n
    assert not np.asarray(padded.mask)[n:].any() and not np.asarray(padded.mask_kinematic)[n:].any()
    assert padded.n_used == obs.n_used


def test_every_long_drive_is_searched_on_subsets_of_one_shape():
    """Drives of any length above the search's size give subsets of one length (one program)."""
    frame, _ = simulate_cornering(VEHICLE, manoeuvre="mixed", duration_s=DURATION_S, seed=11)
    obs = search._padded(cornering_observations(frame, VEHICLE))
    count = 8
    subset, scale = search._search_subset(obs, count)
    assert subset.speed.shape == (count * search.SEARCH_BLOCK,)
    assert scale == float(np.sum(obs.mask)) / float(np.sum(subset.mask)) > 1.0
    # each stretch's two samples at either end are left out of both equations
    inner = np.asarray(subset.mask).reshape(count, search.SEARCH_BLOCK)
    assert not inner[:, :2].any() and not inner[:, -2:].any()
    lengths = {search._search_blocks(n) for n in (9_000, 12_800, 38_400, 153_600)}
    assert lengths == {search.SEARCH_SAMPLES // search.SEARCH_BLOCK}
    assert search._search_blocks(8_000) is None
