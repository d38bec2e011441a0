"""The shared NUTS engine of the wear, wear-history and V_max fits.

One place sets up NumPyro's sampler, runs it and returns the draws by chain with the divergences,
which :func:`~tyrebayes.inference.result.diagnose` then judges. The per-tyre fit has its own
runner (whitened by the Laplace fit, ``tyre/nuts.py``) and the fleet fit caches its sampler per
data shape (``fleet/fit.py``); both hand their draws to the same ``diagnose``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import equinox as eqx
import jax
import numpy as np
from numpyro.infer import MCMC, NUTS, init_to_uniform, init_to_value


class NutsDraws(eqx.Module):
    """Posterior draws of one NUTS run.

    Attributes
    ----------
    samples : dict of str to ndarray
        Each site's draws, shape (chains, draws, ...).
    diverging : ndarray
        Divergent transitions, shape (chains, draws).
    """

    samples: dict[str, np.ndarray]
    diverging: np.ndarray

    def flat(self) -> dict[str, np.ndarray]:
        """The draws with chains stacked, shape (chains × draws, ...)."""
        return {k: v.reshape((-1,) + v.shape[2:]) for k, v in self.samples.items()}


def run_nuts(
    model: Callable,
    model_args: tuple = (),
    *,
    seed: int,
    num_warmup: int,
    num_samples: int,
    num_chains: int = 1,
    init_values: Mapping[str, object] | None = None,
    target_accept_prob: float = 0.8,
    dense_mass: bool = False,
    max_tree_depth: int = 10,
) -> NutsDraws:
    """Run NUTS on ``model(*model_args)``; chains one after another on the CPU.

    Parameters
    ----------
    model : callable
        A NumPyro model.
    model_args : tuple
        Its arguments.
    seed : int
        PRNG seed of the run.
    num_warmup, num_samples, num_chains : int
        Warm-up steps and draws per chain, and chains.
    init_values : mapping, optional
        Starting values per site (default: NumPyro's, uniform in (-2, 2) unconstrained).
    target_accept_prob, dense_mass, max_tree_depth
        NUTS settings (NumPyro's meaning).

    Returns
    -------
    NutsDraws
    """
    init = init_to_uniform if init_values is None else init_to_value(values=dict(init_values))
    kernel = NUTS(
        model,
        init_strategy=init,
        target_accept_prob=target_accept_prob,
        dense_mass=dense_mass,
        max_tree_depth=max_tree_depth,
    )
    mcmc = MCMC(
        kernel,
        num_warmup=num_warmup,
        num_samples=num_samples,
        num_chains=num_chains,
        chain_method="sequential",
        progress_bar=False,
    )
    with jax.default_device(jax.devices("cpu")[0]):
        mcmc.run(jax.random.PRNGKey(seed), *model_args, extra_fields=("diverging",))
    samples = {k: np.asarray(v) for k, v in mcmc.get_samples(group_by_chain=True).items()}
    diverging = np.asarray(mcmc.get_extra_fields(group_by_chain=True)["diverging"])
    return NutsDraws(samples=samples, diverging=diverging)


__all__ = ["NutsDraws", "run_nuts"]
