"""The type-level relations of the V_max inputs: C_y = k_type · C_xr, μ_y = 0.95 μ_type."""

import jax
import jax.numpy as jnp
import pytest

from tyrebayes.inference.vmax.type_relations import lateral_draws


def test_lateral_draws_follow_relations() -> None:
    cy, mu = lateral_draws(jax.random.PRNGKey(0), 40.0, "summer", 4000)
    # median of k is 0.35 -> C_y median 14; mean mu_y 0.95*1.05 (MC error ~0.001)
    assert float(jnp.median(cy)) == pytest.approx(14.0, rel=0.02)
    assert float(jnp.mean(mu)) == pytest.approx(0.9975, abs=0.005)
