"""The one NUTS engine of every sampled fit: per-tyre, fleet, wear, wear history and V_max.

It runs NumPyro's NUTS kernel in a program compiled once per model, sampler settings and shapes of
the model's array arguments, which are *arguments* of that program: a refit on new data of the same
shapes reuses it in memory, and a new process loads it from the persistent compilation cache.
NumPyro's own ``MCMC`` does not give that for chains on several devices: its ``pmap`` closes over
the model's arguments, so every fit embedded its data as constants, compiled again (every
``fit-fleet``, every NUTS ``fit-tyre`` on new data) and left one cache entry per data set.

Chains run side by side, one per CPU device, in equal groups (else one at a time; the
``tyrebayes`` command sets one device per core); each chain's key, start and transitions are
those of NumPyro's ``MCMC`` for the same key (up to round-off). The draws are the constrained
values of the model's sample and deterministic sites, by chain, with the divergences, which
:func:`~tyrebayes.inference.result.diagnose` then judges.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array
from numpyro.infer import NUTS, init_to_uniform, init_to_value


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


def chains_per_run(num_chains: int) -> int:
    """Chains run side by side: one per CPU device, in equal groups (else one at a time).

    JAX sees one CPU device unless told otherwise before it starts
    (``numpyro.set_host_device_count``; the ``tyrebayes`` command sets one device per core).
    Chains are never vectorised on one device: on one core a vectorised gradient of the per-tyre
    model cost more than the single-chain gradients it replaces (measured for the per-tyre
    runner this engine replaced; no benchmark JSON holds the figures), and a vectorised step
    waits for the longest trajectory.
    """
    devices = min(num_chains, jax.local_device_count())
    while num_chains % devices:
        devices -= 1
    return devices


class _Sampler(eqx.Module):
    """What a compiled chain depends on besides its arrays: the model and NUTS settings."""

    model: Callable
    init_strategy: Callable
    target_accept_prob: float
    dense_mass: bool
    max_tree_depth: int
    num_warmup: int
    num_samples: int


def _chain(sampler: _Sampler, static_args, key, init_values, dynamic_args):
    """One chain: warm-up, then ``num_samples`` transitions; constrained draws and divergences.

    ``init_values`` (constrained, by site) start it where given, through ``init_to_value``; the
    model's arguments are ``dynamic_args`` (arrays, traced) merged with ``static_args``.
    """
    args = eqx.combine(dynamic_args, static_args)
    strategy = sampler.init_strategy if init_values is None else init_to_value(values=init_values)
    kernel = NUTS(
        sampler.model,
        init_strategy=strategy,
        target_accept_prob=sampler.target_accept_prob,
        dense_mass=sampler.dense_mass,
        max_tree_depth=sampler.max_tree_depth,
    )
    state = kernel.init(key, sampler.num_warmup, None, model_args=args, model_kwargs={})
    constrained = kernel.postprocess_fn(args, {})

    def transition(state, _):
        state = kernel.sample(state, args, {})
        return state, None

    def draw(state, _):
        state = kernel.sample(state, args, {})
        return state, (constrained(state.z), state.diverging)

    state, _ = jax.lax.scan(transition, state, length=sampler.num_warmup)
    _, (samples, diverging) = jax.lax.scan(draw, state, length=sampler.num_samples)
    return samples, diverging


@functools.lru_cache(maxsize=32)
def _program(sampler: _Sampler, static_leaves: tuple, static_def, per_run: int) -> Callable:
    """``per_run`` chains at once, compiled once per sampler and model-argument structure.

    Takes the chains' keys and starts (leading chains axis) and the model's array arguments;
    gives their draws and divergences (leading chains axis).
    """
    static_args = jax.tree.unflatten(static_def, static_leaves)
    chain = functools.partial(_chain, sampler, static_args)
    if per_run > 1:
        return jax.pmap(chain, in_axes=(0, 0, None))

    @jax.jit
    def one_chain(keys, init_values, dynamic_args):
        first = None if init_values is None else jax.tree.map(lambda v: v[0], init_values)
        return jax.tree.map(lambda x: x[None], chain(keys[0], first, dynamic_args))

    return one_chain


def _cached_program(sampler: _Sampler, static_args, per_run: int) -> Callable:
    leaves, treedef = jax.tree.flatten(static_args)
    try:
        return _program(sampler, tuple(leaves), treedef, per_run)
    except TypeError:  # an unhashable setting among the arguments: compiled for this run only
        return _program.__wrapped__(sampler, tuple(leaves), treedef, per_run)


def run_nuts(
    model: Callable,
    model_args: tuple = (),
    *,
    seed: int | Array,
    num_warmup: int,
    num_samples: int,
    num_chains: int = 1,
    init_values: Mapping[str, object] | None = None,
    init_by_chain: bool = False,
    init_strategy: Callable = init_to_uniform,
    static_argnums: tuple[int, ...] = (),
    target_accept_prob: float = 0.8,
    dense_mass: bool = False,
    max_tree_depth: int = 10,
) -> NutsDraws:
    """Run NUTS on ``model(*model_args)``, chains side by side (:func:`chains_per_run`).

    Parameters
    ----------
    model : callable
        A NumPyro model. The compiled sampler is kept per model *object*: pass the same
        function (or the same ``functools.partial``) to reuse it.
    model_args : tuple
        Its arguments: arrays (the data, traced) and anything else (flags, settings; hashable,
        fixed into the program).
    seed : int or PRNG key
        Randomness of the run.
    num_warmup, num_samples, num_chains : int
        Warm-up steps and draws per chain, and chains.
    init_values : mapping, optional
        Starting values per site, constrained (default: ``init_strategy``).
    init_by_chain : bool
        ``init_values`` has a leading chains axis: each chain starts at its own values.
    init_strategy : callable
        NumPyro's initialisation strategy where ``init_values`` is not given.
    static_argnums : tuple of int
        Arguments fixed into the program whole, arrays included: those a model reads by value
        (its structure depends on them). An array among them makes the program this run's
        alone, compiled again by the next.
    target_accept_prob, dense_mass, max_tree_depth
        NUTS settings (NumPyro's meaning).

    Returns
    -------
    NutsDraws
    """
    key = jax.random.PRNGKey(int(seed)) if isinstance(seed, (int, np.integer)) else seed
    sampler = _Sampler(
        model,
        init_strategy,
        float(target_accept_prob),
        bool(dense_mass),
        int(max_tree_depth),
        int(num_warmup),
        int(num_samples),
    )
    spec = tuple(False if i in static_argnums else eqx.is_array for i in range(len(model_args)))
    dynamic_args, static_args = eqx.partition(tuple(model_args), spec)
    per_run = chains_per_run(num_chains)
    program = _cached_program(sampler, static_args, per_run)
    if init_values is not None:
        init_values = {k: jnp.asarray(v) for k, v in init_values.items()}
        if not init_by_chain:
            init_values = jax.tree.map(
                lambda v: jnp.broadcast_to(v, (num_chains, *v.shape)), init_values
            )
    # NumPyro's MCMC gives chain k the k-th of num_chains keys split from the run's key.
    keys = jax.random.split(key, num_chains) if num_chains > 1 else key[None]
    samples, diverging = [], []
    for start in range(0, num_chains, per_run):
        group = slice(start, start + per_run)
        inits = None if init_values is None else jax.tree.map(lambda v, g=group: v[g], init_values)
        s, d = program(keys[group], inits, dynamic_args)
        samples.append(s)
        diverging.append(d)
    return NutsDraws(
        samples={
            name: np.concatenate([np.asarray(s[name]) for s in samples]) for name in samples[0]
        },
        diverging=np.concatenate([np.asarray(d) for d in diverging]).astype(bool),
    )


__all__ = ["NutsDraws", "chains_per_run", "run_nuts"]
