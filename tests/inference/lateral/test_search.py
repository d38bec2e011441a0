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
