"""Tests of the wear simulator: consistency of features with the true wear, conversions, signs."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes.physics.thermal import StiffnessTemperature, stiffness_at_temperature
from tyrebayes.physics.wear import (
    Abrasability,
    TreadGeometry,
    cumulative_depth_loss,
    volume_to_depth_mm,
    volume_to_mass_g,
)
from tyrebayes.simulate.wear import (
    DutyProfile,
    observe_wear,
    simulate_drives,
)

PROFILE = DutyProfile(drive_duration_s=900.0, dt_s=3.0)


@pytest.fixture(scope="module")
def drives():
    amb = jnp.array([-5.0, 10.0, 30.0, 38.0])
    return simulate_drives(jax.random.PRNGKey(3), 4, amb, 35.0, Abrasability(0.04, 0.02), PROFILE)


def test_conversions_by_hand():
    g = TreadGeometry()
    # 2 pi * 316 * 160 * 0.7 = 222,374.5 mm^2
    assert g.wear_area_mm2 == pytest.approx(222374.49, rel=1e-6)
    assert float(volume_to_depth_mm(222374.49, g)) == pytest.approx(1.0, rel=1e-6)
    assert float(volume_to_mass_g(1000.0, g)) == pytest.approx(1.15)
    with pytest.raises(ValueError, match="void_fraction"):
        TreadGeometry(void_fraction=0.95)
    with pytest.raises(ValueError, match="dt_s"):
        DutyProfile(dt_s=0.0)


def test_binned_features_reproduce_true_wear(drives):
    # volume = gamma_ref sum_b K_b exp(kappa (T_b - 20)) / C_x(T_b): what the inference evaluates
    comp = StiffnessTemperature()
    grid = drives.grid_c
    factor = 0.04 * jnp.exp(0.02 * (grid - 20.0)) / stiffness_at_temperature(35.0, grid, comp)
    rebuilt = drives.kernel_binned @ factor
    # tolerance: 1 K linear binning of exp((kappa + beta) T) and the rectangle vs sample sum
    np.testing.assert_allclose(rebuilt, drives.volume_mm3, rtol=2e-3)
    # the front (driven) axle does most of the work, hotter ambient -> hotter tyre
    assert bool(jnp.all(drives.volume_mm3[:, 0] > drives.volume_mm3[:, 1]))
    assert bool(jnp.all(jnp.diff(drives.tyre_temp_mean_c[:, 0]) > 0))


def test_kappa_zero_matches_constant_gamma(drives):
    amb = jnp.array([-5.0, 10.0, 30.0, 38.0])
    base = simulate_drives(jax.random.PRNGKey(3), 4, amb, 35.0, Abrasability(0.04, 0.0), PROFILE)
    np.testing.assert_array_equal(base.kernel_binned, drives.kernel_binned)
    # hot drives wear more with kappa > 0, cold ones less
    ratio = drives.volume_mm3[:, 0] / base.volume_mm3[:, 0]
    assert float(ratio[0]) < 1.0 < float(ratio[-1])


def test_wear_scale_matches_adac_order_of_magnitude(drives):
    # ADAC: 59-172 g per 1000 km per car set (tyrebayes/data/wear_by_tyre_type.csv)
    per_km = drives.volume_mm3.sum(axis=0) / drives.distance_km.sum()
    set_g = 2 * float(volume_to_mass_g(per_km.sum() * 1000.0, TreadGeometry()))
    assert 20.0 < set_g < 400.0


def test_observations_noise_free_and_drift_sign(drives):
    geom = TreadGeometry()
    obs = observe_wear(
        jax.random.PRNGKey(0), drives, jnp.array([0.0, 1e6]), 0.0, 0.0, 1e-3, (8.0, 7.5), geom
    )
    loss = cumulative_depth_loss(drives.volume_mm3, geom)
    np.testing.assert_allclose(obs.depth_mm[:2], [8.0, 7.5])
    np.testing.assert_allclose(obs.depth_mm[2:], [8.0 - loss[-1, 0], 7.5 - loss[-1, 1]])
    # front wears faster -> its radius shrinks relative to the rear: drift falls from the offset
    assert bool(jnp.all(jnp.diff(obs.radius_drift) < 0))
    assert float(obs.radius_drift[0]) < 1e-3
