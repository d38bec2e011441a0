"""V_max inputs from the type-level relations: C_y = k_type · C_xr, μ_y = 0.95 μ_type.

The relations are assumptions (no cornering data exist for the thesis sets):

* lateral stiffness: C_y = k_type · C_xr [1/rad], k ~ LogNormal(log k_type, 0.15) with k_type =
  0.45 (winter), 0.40 (all-season), 0.35 (summer): softer winter treads lose less cornering
  stiffness per unit of longitudinal stiffness (block bending shares both);
* lateral friction on dry asphalt at 5-10 °C: μ_y = 0.95 · μ_x, μ_x ~ Normal(μ_type, 0.05) with
  μ_type = 0.95 (winter), 1.00 (all-season), 1.05 (summer).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .inputs import TYPE_SURFACE, VmaxInputs

#: Median ratio k_type = C_y / C_xr per tyre type [1/rad per unit C_xr].
K_TYPE = {"winter": 0.45, "all_season": 0.40, "summer": 0.35}
#: Mean longitudinal peak friction μ_type per tyre type on dry asphalt at 5-10 °C [-].
MU_TYPE = {"winter": 0.95, "all_season": 1.00, "summer": 1.05}
#: μ_y / μ_x [-].
MU_Y_RATIO = 0.95


def lateral_draws(
    key: Array, c_xr: float, tyre_type: str, n: int
) -> tuple[Float[Array, "n"], Float[Array, "n"]]:
    """Draws of (C_y [1/rad], μ_y) for a tyre of measured C_xr via the type-level relations."""
    k1, k2 = jax.random.split(key)
    k = K_TYPE[tyre_type] * jnp.exp(0.15 * jax.random.normal(k1, (n,)))
    mu_x = MU_TYPE[tyre_type] + 0.05 * jax.random.normal(k2, (n,))
    return k * c_xr, MU_Y_RATIO * mu_x


def type_vmax_inputs(key: Array, c_xr, tyre_type: str, n: int, note: str = "") -> VmaxInputs:
    """Draws of the type-level relations: C_y = k_type · C_xr on both axles, μ_y = 0.95 μ_type.

    Parameters
    ----------
    key : jax.Array
        PRNG key.
    c_xr : float or array_like
        The tyre's C_xr [-]: a value, or a fit's posterior draws (resampled with replacement).
    tyre_type : str
        One of ``winter``, ``all_season``, ``summer``.
    n : int
        Number of draws.
    note : str
        Why the type relations are used (carried into the result).

    Returns
    -------
    VmaxInputs
        ``lateral_source`` and ``mu_y_source`` ``"type_prior"``, surface :data:`TYPE_SURFACE`.

    Examples
    --------
    >>> import jax
    >>> x = type_vmax_inputs(jax.random.PRNGKey(0), 35.0, "all_season", 8)
    >>> x.lateral_source, x.mu_y_source, x.n_draws
    ('type_prior', 'type_prior', 8)
    """
    if tyre_type not in K_TYPE:
        raise ValueError(f"tyre_type: expected one of {tuple(K_TYPE)}, got {tyre_type!r}")
    k_ratio, mu_y = lateral_draws(key, 1.0, tyre_type, n)
    c = np.atleast_1d(np.asarray(c_xr, float))
    c_draws = c[np.asarray(jax.random.randint(jax.random.fold_in(key, 7), (n,), 0, c.size))]
    c_y = np.asarray(k_ratio) * c_draws
    return VmaxInputs(c_y, c_y, np.asarray(mu_y), "type_prior", "type_prior", TYPE_SURFACE, note)
