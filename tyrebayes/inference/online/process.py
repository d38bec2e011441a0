"""The online estimator's process model: how θ moves between two steps.

Two kinds of movement, each a stated number of :mod:`.config` (none fitted to the external
drives):

- **random-walk drift** (:data:`~.config.DRIFT_PER_SQRT_S`): slow change of the tyre and the
  drive (wear, pressure, load share) adds ``drift² · Δt`` to a coordinate's variance;
- **reversion to the prior** (:data:`~.config.REVERSION_S`): the noise scales λ_ρ and λ_σ are
  factors on the noise the stream measured locally, which is right on average (their prior's
  median is 1) but not at every stretch of road: road surface and speed regime change within a
  drive. Each log factor is a stationary Gauss-Markov (Ornstein-Uhlenbeck) process about the
  prior with the prior's variance and a correlation time τ: over Δt the mean moves towards the
  prior's by ``a = exp(−Δt/τ)`` and the variance gains the prior's times ``1 − a²``
  (Uhlenbeck & Ornstein 1930: the process's exact transition over Δt, not a discretisation).
  Data of one stretch therefore weigh on the factor for about τ, and a block the Normal errors
  cannot explain (a feature error's burst of outlying slips) stops setting the noise level for
  the rest of the drive.

Where τ is infinite the coordinate keeps its mean and covariance exactly (``a = 1``).
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from .parameters import GaussianPrior


def predict(
    prior: GaussianPrior,
    mean: Float[Array, "p"],
    cov: Float[Array, "p p"],
    elapsed_s: Float[Array, ""] | float,
    drift_sd_per_sqrt_s: Float[Array, "p"],
    reversion_s: Float[Array, "p"],
) -> tuple[Float[Array, "p"], Float[Array, "p p"]]:
    """θ's Gaussian ``elapsed_s`` seconds later: drift and reversion to ``prior``.

    Parameters
    ----------
    prior : GaussianPrior
        The type prior; reverting coordinates move towards its mean and marginal variance.
    mean, cov : Array
        θ's Gaussian at the last step.
    elapsed_s : Array
        Seconds since the last step (≥ 0).
    drift_sd_per_sqrt_s : Array
        Random-walk sd of each coordinate per √s.
    reversion_s : Array
        Correlation time τ of each coordinate [s]; ``inf`` where it does not revert.

    Returns
    -------
    (mean, cov)
        The predicted Gaussian.
    """
    a = jnp.exp(-elapsed_s / reversion_s)
    reverting = jnp.isfinite(reversion_s)
    prior_var = jnp.diag(prior.cov)
    mean = jnp.where(reverting, prior.mean + a * (mean - prior.mean), mean)
    added = drift_sd_per_sqrt_s**2 * elapsed_s + jnp.where(reverting, prior_var * (1 - a**2), 0.0)
    return mean, a[:, None] * cov * a[None, :] + jnp.diag(added)


__all__ = ["predict"]
