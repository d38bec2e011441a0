"""Where the per-tyre MAP search starts, and on which windows it searches.

The posterior of one long drive has spurious local modes (:data:`MAP_STARTS`); the search runs
from several starts on a subset of the windows (:func:`search_windows`), and the refinement on
all of them (:mod:`tyrebayes.inference.tyre.laplace`).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree
from numpyro.distributions import constraints
from numpyro.distributions.transforms import biject_to

from ...internal.device_arrays import device_array
from .data import TyreObservations
from .model import TyrePriors

# Windows the multi-start search reads on a tyre set of at least SUBSET_FROM padded windows:
# every k-th real window, k the smallest stride that leaves at most this many (more than half
# as many; about a third of a one-hour 100 Hz drive at most), padded to exactly this many. A
# fixed length makes the search one compiled program for every set that large, whatever its
# padded size: a fleet worker loads it once, where a program per padded shape cost each new
# shape its largest executable (1.3 of the 1.9 CPU s a new shape's fit spent loading its 29
# executables from the persistent cache, one-off).
SEARCH_WINDOWS = 3072
SUBSET_FROM = 4608


def searches_subset(size: int) -> bool:
    """Whether a fit of ``size`` padded windows searches a subset (:func:`search_windows`).

    The search only has to find the right basin; the refinement on all windows finds the mode.
    On one full one-hour drive the spurious mode lay ~3,000 nats below the right one, so a
    quarter of the windows should still keep a gap of several hundred (an estimate; the
    spurious-mode regression test and the recovery benchmark pass with it). A fixed budget keeps
    the search's cost from growing with the data: ten one-hour drives pay one search, not ten.
    Shorter sets search every window.
    """
    return size >= SUBSET_FROM


def search_windows(obs: TyreObservations) -> tuple[TyreObservations, float]:
    """The search's windows (:data:`SEARCH_WINDOWS` of them, padding at the end) and the ratio
    of all real windows to the real windows among them.

    Every k-th real window in order, so each drive keeps its share; the blocks they fall in
    are numbered again from 0 (a block's slip offset is integrated out over the windows present:
    :func:`~tyrebayes.inference.tyre.likelihood.block_offsets`).
    """
    mask = np.asarray(obs.mask)
    n = int(mask.sum())
    stride = -(-n // SEARCH_WINDOWS)
    take = np.flatnonzero(mask)[::stride]
    # Padding repeats the last window taken, masked: finite values that nothing counts.
    index = np.concatenate([take, np.repeat(take[-1:], SEARCH_WINDOWS - take.size)])
    arrays = {
        f.name: np.asarray(getattr(obs, f.name))[index]
        for f in dataclasses.fields(obs)
        if not f.metadata.get("static")
    }
    arrays["mask"] = np.arange(SEARCH_WINDOWS) < take.size
    blocks = arrays["block_index"]
    arrays["block_index"] = np.unique(blocks, return_inverse=True)[1].astype(blocks.dtype)
    arrays = {k: device_array(v) for k, v in arrays.items()}
    return dataclasses.replace(obs, **arrays), n / take.size


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
