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


def _observations(ay: np.ndarray):
    import jax.numpy as jnp

    from tyrebayes.inference.lateral import CorneringObservations

    n = ay.size
    return CorneringObservations(
        speed=jnp.full(n, 20.0),
        yaw_rate=jnp.asarray(ay / 20.0),
        yaw_acceleration=jnp.zeros(n),
        ay=jnp.asarray(ay),
        steering=jnp.zeros(n),
        mask=jnp.ones(n, bool),
        mask_kinematic=jnp.ones(n, bool),
        longitudinal=jnp.zeros(n, bool),
        ax=jnp.zeros(n),
        dt_s=0.1,
        road_wheel=False,
        mass_kg=jnp.asarray(1500.0),
        wheelbase_m=jnp.asarray(2.7),
        cog_to_front_axle_m=jnp.asarray(1.1),
        yaw_inertia_kgm2=jnp.asarray(2500.0),
        steering_ratio=jnp.asarray(15.0),
        cornering_seconds=jnp.asarray(100.0),
    )


def test_a_long_drive_is_fitted_on_its_stretches_with_the_most_cornering():
    """Every drive over FIT_BLOCKS stretches gives one length; the cornering stretches are all
    kept, a share of straight ones too; ends next to a dropped stretch leave both equations."""
    blocks, block = 3 * search.FIT_BLOCKS, search.SEARCH_BLOCK
    rng = np.random.default_rng(0)
    cornering = np.sort(rng.choice(blocks, 100, replace=False))
    ay = np.zeros((blocks, block))
    ay[cornering] = 3.0
    obs = _observations(ay.reshape(-1))
    fit = search._fit_stretches(obs)
    assert fit.speed.shape == (search.FIT_BLOCKS * block,)
    kept_ay = np.asarray(fit.ay).reshape(search.FIT_BLOCKS, block)
    assert (kept_ay[:, 10] == 3.0).sum() == cornering.size
    # two samples at each end of a run of kept stretches are out of both masks, none inside
    mask = np.asarray(fit.mask)
    assert not mask[:2].any() and not mask[-2:].any()
    assert np.array_equal(mask, np.asarray(fit.mask_kinematic))
    assert (
        mask.sum() < fit.speed.shape[0] and mask.sum() >= fit.speed.shape[0] - 4 * search.FIT_BLOCKS
    )
    assert search._fit_stretches(
        _observations(ay[: search.FIT_BLOCKS].reshape(-1))
    ).speed.shape == (search.FIT_BLOCKS * block,)
