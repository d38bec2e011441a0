"""Where the per-tyre MAP search starts, and on which windows it searches.

The posterior of one long drive has spurious local modes (:data:`MAP_STARTS`); the search runs
from several starts on a subset of the windows (:func:`_search_stride`), and the refinement on
all of them (:mod:`tyrebayes.inference.tyre.laplace`).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
from jax.flatten_util import ravel_pytree
from numpyro.distributions import constraints
from numpyro.distributions.transforms import biject_to

from .data import TyreObservations
from .model import TyrePriors

# Windows the multi-start search reads at most (about a quarter of a one-hour 100 Hz drive).
SEARCH_WINDOWS = 2304


def _search_stride(size: int) -> int:
    """Every how many windows the multi-start search reads: about :data:`SEARCH_WINDOWS` of them.

    The search only has to find the right basin; the refinement on all windows finds the mode.
    On one full one-hour drive the spurious mode lay ~3,000 nats below the right one, so a
    quarter of the windows should still keep a gap of several hundred (an estimate; the
    spurious-mode regression test and the recovery benchmark pass with it). A fixed budget keeps
    the search's cost from growing with the data: ten one-hour drives pay one search, not ten.
    Short drives keep every window.
    """
    return max(1, size // SEARCH_WINDOWS)


def _every_nth_window(obs: TyreObservations, n: int) -> TyreObservations:
    """The observations of every n-th window (padding stays at the end, so it stays padding)."""
    if n == 1:
        return obs
    arrays = {
        f.name: getattr(obs, f.name)[::n]
        for f in dataclasses.fields(obs)
        if not f.metadata.get("static")
    }
    return dataclasses.replace(obs, **arrays)


def _drive_moments(obs: TyreObservations):
    """Per-drive means of slip and force and their centred second moments (slip windows only).

    Returns ``(slip_mean, rho_mean, rho_var, slip_rho_cov, slip_var)``, each of shape
    ``(n_drives,)``; a drive without slip windows gets zeros.
    """
    weight = (obs.mask & ~obs.at_limit).astype(obs.slip.dtype)
    count = jnp.maximum(jax.ops.segment_sum(weight, obs.drive_index, obs.n_drives), 1.0)

    def mean(x):
        return jax.ops.segment_sum(weight * x, obs.drive_index, obs.n_drives) / count

    slip_mean, rho_mean = mean(obs.slip), mean(obs.rho)
    slip = obs.slip - slip_mean[obs.drive_index]
    rho = obs.rho - rho_mean[obs.drive_index]
    return slip_mean, rho_mean, mean(rho**2), mean(slip * rho), mean(slip**2)


def _stiffness_start(moments, priors: TyrePriors) -> jax.Array:
    """A data scale for the MAP starts' C_xr: least-squares slope of force on slip within drives.

    ``moments`` is what :func:`_drive_moments` returns.

    Attenuated by the slip noise (below the truth), cheap, and on the data's scale where the
    prior median (35) may be far from it (``MAP_STARTS``).
    """
    *_, slip_rho_cov, slip_var = moments
    slope = jnp.sum(slip_rho_cov) / jnp.sum(slip_var)
    usable = jnp.isfinite(slope) & (slope > 0)
    return jnp.clip(jnp.where(usable, slope, priors.c_xr_median), 5.0, 200.0)


# Starts of the MAP search as (C_xr factor on the within-drive least-squares slope, μ_max
# quantile in prior sds). The posterior of one long drive has spurious local modes: μ_max below
# the largest measured forces, where the inverse maps them to the peak slip, and C_x up to twice
# the truth (one-hour drives, brush truth: from the prior median alone 14 of 50 drives without
# ABS and 2 of 50 with it ended there, thousands of nats below the right mode; no single start
# tried avoided them all). The slope is attenuated by slip noise (~0.75 of the truth), hence 1.35.
MAP_STARTS = ((1.0, 0.0), (1.35, 0.0), (1.0, 2.0), (1.35, 2.0))


def _start(flat_init, unravel, obs, priors, stiffness_factor, mu_sds):
    """One starting point of the MAP search (unconstrained, flat).

    C_xr and μ_max as ``MAP_STARTS`` says; each drive's force level and spread from its measured
    forces and its slip offset from its mean slip and force at that C_xr (so that BFGS does not
    spend hundreds of steps walking forty per-drive parameters in from the prior medians); the
    rest at ``flat_init``.
    """
    start = unravel(flat_init)
    positive = biject_to(constraints.positive).inv
    moments = _drive_moments(obs)
    c_xr = stiffness_factor * _stiffness_start(moments, priors)
    start["c_xr"] = positive(c_xr)
    mu = priors.mu_median(obs.surfaces) * jnp.exp(mu_sds * priors.mu_log_sd(obs.surfaces))
    start["mu_max"] = positive(mu)
    slip_mean, rho_mean, rho_var, *_ = moments
    start["force_level"] = rho_mean
    start["force_spread"] = positive(jnp.sqrt(jnp.maximum(rho_var, 1e-6)))
    start["slip_offset"] = jnp.clip(slip_mean - rho_mean / c_xr, -0.02, 0.02)
    return ravel_pytree(start)[0]
