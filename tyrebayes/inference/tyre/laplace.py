"""The per-tyre MAP search and Laplace approximation (compiled once per data shape).

The fast path's engine, and NUTS's whitening: multi-start BFGS in Hessian-whitened coordinates
on a subset of windows, refinement on all, and the block-arrow Hessian of the drives' parameters.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jax.flatten_util import ravel_pytree
from numpyro.infer.util import constrain_fn, potential_energy

from ...internal.stored_program import stored_program
from .block_hessian import _block_hessian
from .layout import _model_layout
from .map_starts import MAP_STARTS, SEARCH_WINDOWS, _start, search_windows, searches_subset
from .model import TyrePriors


class LaplaceCore(NamedTuple):
    """The fast path's compiled programs for one data shape (:func:`_laplace_core`).

    ``mode(start, obs, whiten, search)`` gives the mode, the optimiser's outcome (a code:
    :func:`optimiser_outcome`), the whitening W its last BFGS run used and the constrained
    sites at the mode (deterministic sites included). With ``search`` true the mode is searched
    for from the starts of ``MAP_STARTS`` (``start`` is ``flat0``, ``whiten`` unused): on every
    window of a short set, else on a subset (:func:`~.map_starts.search_windows`, one program for
    every size) whose best mode one BFGS run on all windows then refines. False, the mode comes
    from that one BFGS run started at ``start`` in the coordinates ``whiten`` gives: the second
    pass of a fit, whose slip weights move the posterior's width and barely its centre, keeps
    the basin the search found and the whitening of its refinement (a Hessian of every window
    not paid again).

    ``laplace(mode, obs, key)`` gives the smallest Hessian eigenvalue at the mode, the scale S
    with S S' = H⁻¹ (eigenvalues floored) and the constrained Laplace draws. The first pass of
    a fit needs none: its slip weights read the residuals at its mode.

    Each is traced once per shape and kept on disk
    (:func:`~tyrebayes.internal.stored_program.stored_program`).
    """

    mode: Callable
    laplace: Callable
    flat0: jax.Array


# BFGS stops when a step moves every whitened coordinate (posterior sds, where the whitening
# is the Hessian's) by less than BFGS_ATOL and the log density by less than about
# BFGS_RTOL·|f|. 1e-4 sds is far below what a fit reports (the Laplace draws' mean carries
# 1/√2000 = 0.022 sds of Monte-Carlo error) and above the resolution of the log density itself:
# |f| is ~10⁵ nats for a few hours of windows, so round-off (ε|f| ≈ 2e-11 nats) hides steps
# shorter than √(2ε|f|) ≈ 7e-6 sds, and a tolerance below that left BFGS wandering in
# round-off: three tyre sets of 1.6-3.2 h took 66-74 steps on all windows at 1e-8 and 21-29 at
# 1e-4, with every reported mean and sd equal to 1e-5 of an sd.
BFGS_ATOL = 1e-4
BFGS_RTOL = 1e-8


@functools.lru_cache(maxsize=16)
def _laplace_core(
    priors_key: tuple, model: str, obs_key: tuple, num_draws: int, max_steps: int
) -> LaplaceCore:
    """The MAP search, refit and Laplace draws for one data shape (:class:`LaplaceCore`)."""
    posterior = _posterior(priors_key, model, obs_key[1:], max_steps)
    key = (priors_key, model, obs_key, num_draws, max_steps)
    refined = stored_program(_refine_program(posterior), ("tyre-refine-core", *key))
    if searches_subset(obs_key[0]):
        searched = _subset_search(priors_key, model, obs_key[1:], max_steps)

        def mode(start, obs, whiten, search: bool):
            if search:
                coarse, windows = search_windows(obs)
                start, whiten = searched(start, coarse, np.asarray(windows, obs.slip.dtype))
            return refined(start, obs, whiten)

    else:
        priors = TyrePriors(*priors_key)
        whole = stored_program(_search_program(posterior, priors), ("tyre-search-core", *key))

        def mode(start, obs, whiten, search: bool):
            return whole(start, obs) if search else refined(start, obs, whiten)

    return LaplaceCore(
        mode=mode,
        laplace=stored_program(_laplace_program(posterior, num_draws), ("tyre-laplace-core", *key)),
        flat0=posterior.flat0,
    )


@functools.lru_cache(maxsize=16)
def _posterior(priors_key: tuple, model: str, drives_key: tuple, max_steps: int) -> _Posterior:
    """The posterior of a data shape's drives and surfaces (``drives_key``), whatever its number
    of windows."""
    numpyro_model, template, params = _model_layout(priors_key, model, (None, *drives_key))
    flat0, unravel = ravel_pytree(params)
    return _Posterior(
        numpyro_model, flat0, unravel, _block_hessian(numpyro_model, template, params), max_steps
    )


@functools.lru_cache(maxsize=16)
def _subset_search(priors_key: tuple, model: str, drives_key: tuple, max_steps: int) -> Callable:
    """The search on :func:`~.map_starts.search_windows`' windows: one program for every data
    shape of these drives and surfaces that searches a subset (:func:`~.map_starts.
    searches_subset`)."""
    posterior = _posterior(priors_key, model, drives_key, max_steps)
    best_start = _best_start(posterior, TyrePriors(*priors_key))

    @jax.jit
    def subset_search_program(start, coarse, windows):
        # The refinement's whitening from the search's windows, scaled to all windows (the
        # prior's curvature scaled with them: only the first steps' lengths depend on it). A
        # Hessian of every window cost about as much as the refinement's BFGS steps together.
        mode, _, _ = best_start(start, coarse)
        return mode, posterior.whitening_at(mode, coarse, windows)

    key = ("tyre-subset-search", priors_key, model, (SEARCH_WINDOWS, *drives_key), max_steps)
    return stored_program(subset_search_program, key)


class _Posterior(NamedTuple):
    """The model's posterior over the flat unconstrained parameters, and BFGS on it."""

    model: Callable
    flat0: jax.Array  # the prior medians, flat: where a search starts
    unravel: Callable  # flat vector -> the model's unconstrained sites
    hessian_at: Callable  # block-arrow Hessian (:func:`._block_hessian`)
    max_steps: int

    def negative_log_posterior(self, flat, obs):
        """The potential energy at the flat unconstrained parameters."""
        return potential_energy(self.model, (obs,), {}, self.unravel(flat))

    def constrained(self, flat, obs):
        """The constrained sites at the flat parameters, deterministic sites included."""
        return constrain_fn(self.model, (obs,), {}, self.unravel(flat), return_deterministic=True)

    def whitening_at(self, flat, obs, scale=1.0):
        """W = V |Λ|^(-1/2) from the Hessian at ``flat`` (times ``scale``), eigenvalues floored."""
        # BFGS starts from the identity, but the posterior's scales differ by orders of magnitude
        # (a slip offset known to 1e-5, a force level to 1e-2) and its parameters are
        # correlated (C_xr with μ_max and the slip offsets). It works in y with
        # x = start + W y, W = V |Λ|^(-1/2) from the Hessian at the start (eigenvalues in
        # absolute value, floored: far from the mode H need not be positive definite), so that
        # its first step is a Newton step. Steps per BFGS run, search (four starts) and
        # refinement, with the data-driven starts of _start (brush model, measured before the
        # shaped model became the default, at the former tolerance 1e-8): one one-hour drive
        # 45-56 and 40 (diagonal rescaling x = start + y/√|H_ii|: 69-74 and 84); ten stacked
        # one-hour drives 32-53 and 49 (79-83 and 103). Without any rescaling a one-hour drive
        # took 240-360.
        # ``scale`` multiplies the Hessian: that of a subset of the windows, scaled to all of
        # them, whitens about as well at a fraction of the cost.
        hessian = scale * self.hessian_at(lambda f: self.negative_log_posterior(f, obs), flat)
        finite = jnp.all(jnp.isfinite(hessian))
        eigenvalues, vectors = jnp.linalg.eigh(jnp.where(finite, hessian, jnp.eye(len(flat))))
        return vectors / jnp.sqrt(jnp.maximum(jnp.abs(eigenvalues), 1.0))[None, :]

    def minimise_whitened(self, flat_start, obs, whiten):
        """One BFGS run from ``flat_start`` in the coordinates ``whiten`` gives."""

        def rescaled(y, obs):
            return self.negative_log_posterior(flat_start + whiten @ y, obs)

        solver = optx.BFGS(rtol=BFGS_RTOL, atol=BFGS_ATOL)
        sol = optx.minimise(
            rescaled,
            solver,
            jnp.zeros_like(flat_start),
            args=obs,
            max_steps=self.max_steps,
            throw=False,
        )
        return flat_start + whiten @ sol.value, sol.result, whiten

    def minimise_from(self, flat_start, obs):
        """One BFGS run from ``flat_start``, whitened by the Hessian there."""
        return self.minimise_whitened(flat_start, obs, self.whitening_at(flat_start, obs))


def _best_start(posterior: _Posterior, priors: TyrePriors) -> Callable:
    """The multi-start search: BFGS from each start of ``MAP_STARTS`` on ``obs``; returns the
    best run's mode, its outcome and its whitening."""

    def best_start(flat_init, obs):
        # Several starts find the basin (module comment at MAP_STARTS).
        starts = jax.vmap(lambda c, m: _start(flat_init, posterior.unravel, obs, priors, c, m))(
            *map(jnp.asarray, zip(*MAP_STARTS, strict=True))
        )
        # One start after another (lax.map): vmapped, the four starts' Hessians and BFGS states
        # are held at once, and every start runs as many steps as the slowest.
        values, results, whitens = jax.lax.map(lambda s: posterior.minimise_from(s, obs), starts)
        energies = jax.vmap(posterior.negative_log_posterior, (0, None))(values, obs)
        ok = (results == optx.RESULTS.successful) & jnp.isfinite(energies)
        best = jnp.argmin(jnp.where(ok, energies, jnp.inf))
        best = jnp.where(ok.any(), best, jnp.argmin(jnp.nan_to_num(energies, nan=jnp.inf)))
        return values[best], jax.tree.map(lambda r: r[best], results), whitens[best]

    return best_start


def _search_program(posterior: _Posterior, priors: TyrePriors) -> Callable:
    """The jitted search on every window: ``search(start, obs)`` gives the mode, its outcome
    code, its whitening and the constrained sites there (what ``refine`` gives)."""
    best_start = _best_start(posterior, priors)

    @jax.jit
    def search_program(start, obs):
        mode, result, whiten = best_start(start, obs)
        return mode, _outcome_code(result), whiten, posterior.constrained(mode, obs)

    return search_program


def _refine_program(posterior: _Posterior) -> Callable:
    """The jitted refinement: ``refine(start, obs, whiten)``, one BFGS run on all windows from
    ``start`` in the coordinates ``whiten`` gives; returns its mode, outcome code, whitening and
    the constrained sites at its mode.

    The searches and the refinement are compiled apart, not as one program: XLA's compilation
    of one program holding both set a first fit's peak memory (``fit-tyre`` in a fresh process,
    ``benchmarks/results/lateral_speed.json``), and a fit's second pass needs the refinement
    alone.
    """

    @jax.jit
    def refine_program(start, obs, whiten):
        mode, result, whiten = posterior.minimise_whitened(start, obs, whiten)
        return mode, _outcome_code(result), whiten, posterior.constrained(mode, obs)

    return refine_program


def _laplace_program(posterior: _Posterior, num_draws: int) -> Callable:
    """The jitted ``laplace`` program of :class:`LaplaceCore`: Hessian, scale and draws."""

    @jax.jit
    def laplace_program(mode, obs, key):
        hessian = posterior.hessian_at(lambda f: posterior.negative_log_posterior(f, obs), mode)
        eigenvalues, vectors = jnp.linalg.eigh(hessian)
        finite = jnp.all(jnp.isfinite(hessian))
        # A non-positive-definite Hessian still gives draws (eigenvalues floored) so that the
        # result can be inspected; it is flagged as not converged.
        floored = jnp.where(finite, jnp.maximum(eigenvalues, 1e-6), 1.0)
        vectors = jnp.where(finite, vectors, jnp.eye(len(mode)))
        # z = mode + S u with S S' = H⁻¹: the Laplace draws, and NUTS's whitening.
        scale = vectors / jnp.sqrt(floored)[None, :]
        eps = jax.random.normal(key, (num_draws, len(mode)), dtype=mode.dtype)
        z = mode[None, :] + eps @ scale.T
        draws = jax.vmap(lambda f: posterior.constrained(f, obs))(z)
        min_eig = jnp.where(finite, eigenvalues.min(), -jnp.inf)
        return min_eig, scale, draws

    return laplace_program


# Outcomes of an optimistix solve by name, in the order of the codes the core returns.
_OUTCOMES = tuple(
    name
    for name in (
        "successful",
        "max_steps_reached",
        "nonlinear_max_steps_reached",
        "nonlinear_divergence",
        "singular",
        "breakdown",
        "stagnation",
        "conlim",
        "nonfinite_input",
        "nonfinite",
    )
    if hasattr(optx.RESULTS, name)
)


def _outcome_code(result) -> jax.Array:
    """An optimistix result as an integer (its place in ``_OUTCOMES``; one past it: another).

    A plain integer crosses a stored program's boundary (:mod:`tyrebayes.internal.stored_program`),
    where optimistix's result type would not.
    """
    hits = jnp.stack([result == getattr(optx.RESULTS, name) for name in _OUTCOMES])
    return jnp.where(hits.any(), jnp.argmax(hits), len(_OUTCOMES)).astype(jnp.int32)


def optimiser_outcome(code) -> str:
    """``"successful"`` or optimistix's message for an outcome code of the core."""
    code = int(code)
    if code == 0:
        return "successful"
    if code < len(_OUTCOMES):
        return str(optx.RESULTS[getattr(optx.RESULTS, _OUTCOMES[code])])
    return "the optimiser stopped with an outcome this package does not name"
