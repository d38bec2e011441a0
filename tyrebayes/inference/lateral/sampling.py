"""The lateral posterior's draws: Laplace N(mode, H⁻¹) through the constraints, or NUTS.

The Laplace path draws about the weighted mode (:func:`~.mode._weighted_mode`) with the inverse
Hessian there; NUTS starts at that mode, with a dense mass matrix.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from numpyro.infer import MCMC, NUTS, init_to_value

from .mode import _constrain
from .model import lateral_model


def _covariance_root(hess: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """A square root S of H⁻¹ (S S' = H⁻¹), and the problems found in H.

    A Hessian that is not finite or not positive definite is a failed fit (said in its
    diagnostics); its draws then come from the Hessian with the non-positive directions given
    the unconstrained prior's unit scale, wide where the data say nothing.
    """
    hess = 0.5 * (hess + hess.T)
    problems = []
    if not np.all(np.isfinite(hess)):
        problems.append("Hessian at the mode is not finite")
        hess = np.eye(hess.shape[0])
    eig, vec = np.linalg.eigh(hess)
    if eig.min() <= 0:
        problems.append("Hessian at the mode is not positive definite")
        eig = np.where(eig > 0, eig, 1.0)
    return vec / np.sqrt(eig)[None, :], problems


def _nuts(obs, priors, mu_prior, weights, init: dict, key, settings: tuple[int, int, int]):
    """NUTS draws (by chain) from ``init`` and the divergences: ``(samples, sample_stats)``.

    ``mu_prior``: μ_y's prior, median and log-sd (:meth:`~.model.LateralPriors.mu_y_prior`)."""
    num_chains, num_warmup, num_samples = settings
    kernel = NUTS(
        lateral_model,
        init_strategy=init_to_value(
            values={k: v for k, v in init.items() if k != "understeer_gradient"}
        ),
        dense_mass=True,
    )
    mcmc = MCMC(
        kernel,
        num_warmup=num_warmup,
        num_samples=num_samples,
        num_chains=num_chains,
        chain_method="sequential",
        progress_bar=False,
    )
    mcmc.run(key, obs, priors, mu_prior, weights, extra_fields=("diverging",))
    samples = {k: np.asarray(v) for k, v in mcmc.get_samples(group_by_chain=True).items()}
    diverging = np.asarray(mcmc.get_extra_fields(group_by_chain=True)["diverging"])
    return samples, {"diverging": diverging}


def _laplace(mode, chol, obs, priors, key, num_draws: int) -> dict:
    """Laplace draws (one chain) of the constrained sites, K included: mode + S z, z ~ N(0, I)."""
    z = np.asarray(jax.random.normal(key, (num_draws, mode.shape[0]), dtype=mode.dtype))
    flat = np.asarray(mode)[None, :] + z @ chol.T
    draws = _constrain(jnp.asarray(flat), obs, priors)
    return {k: np.asarray(v)[None] for k, v in draws.items()}
