"""The per-tyre MAP search and Laplace approximation (compiled once per data shape).

The fast path's engine, and NUTS's whitening: multi-start BFGS in Hessian-whitened coordinates
on a subset of windows, refinement on all, and the block-arrow Hessian of the drives' parameters.
"""

from __future__ import annotations

import dataclasses
import functools
import io
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jax.flatten_util import ravel_pytree
from numpyro import handlers
from numpyro.distributions import constraints
from numpyro.distributions.transforms import biject_to
from numpyro.infer import init_to_median
from numpyro.infer.util import constrain_fn, initialize_model, potential_energy

from ..._io import atomic_write_bytes
from ...internal.stored_program import kept_file, stored_program
from .data import TyreObservations
from .model import (
    TyrePriors,
    tyre_model,
)


def _model_layout(priors_key: tuple, kind: str, obs_key: tuple):
    """The model for one data shape, a template of that shape and its median parameters.

    Returns ``(model, template, params)``; ``params`` are unconstrained, keyed by site, and fix
    the flat layout (``ravel_pytree``) that the Laplace core and the NUTS runner share. They
    depend on the drives and surfaces, not on the number of windows: the model has no latent
    per-window site, and ``init_to_median`` draws from the priors only. The template therefore
    has :data:`LAYOUT_WINDOWS` windows whatever the data's length, so that the layout (numpyro's
    initialisation, run op by op: seconds, and memory a fleet worker keeps) is made once per
    number of drives and surfaces, not once per padded length.
    """
    _, n_drives, surfaces = obs_key
    return _layout(priors_key, kind, n_drives, surfaces)


# Windows of the template :func:`_model_layout` traces the model on (any length gives the same
# parameters; tests/inference/tyre/test_laplace.py checks it).
LAYOUT_WINDOWS = 256


@functools.lru_cache(maxsize=16)
def _layout(priors_key: tuple, kind: str, n_drives: int, surfaces: tuple):
    model = partial(tyre_model, priors=TyrePriors(*priors_key), kind=kind)
    template = _template_observations(LAYOUT_WINDOWS, n_drives, surfaces)
    stored = _stored_medians_path((priors_key, kind, n_drives, surfaces))
    params = _read_medians(stored)
    if params is not None:
        return model, template, params

    # init_to_median draws a batch of prior samples; numpyro broadcasts it by rank promotion.
    with jax.numpy_rank_promotion("allow"):
        init = initialize_model(
            jax.random.PRNGKey(0), model, model_args=(template,), init_strategy=init_to_median
        )
    # Run op by op, the initialisation compiled a one-op program for each of its few hundred
    # operations, which stay loaded under every later fit's peak; they are not needed again.
    # Compiled as one program instead, the medians moved by round-off, and fits started from
    # them moved far more than that on the external drives (the MAP search is sensitive to its
    # start): left op by op, the results stay as they were.
    _drop_op_by_op_programs()
    params = init.param_info.z
    _write_medians(stored, params)
    return model, template, params


def _stored_medians_path(key: tuple) -> Path | None:
    """Where the layout's medians of ``key`` are kept: beside JAX's compilation cache, if on.

    The op-by-op initialisation is part of what a new process (a fleet worker, every
    ``fit-tyre``) pays before its first fit of a number of drives and surfaces
    (``benchmarks/results/stored_program.json`` measures it with the traced programs); its
    result depends on ``key``, on the package's model code and on numpyro's version.
    """
    import numpyro

    return kept_file("tyrebayes-layouts", (key, numpyro.__version__), ".npz")


def _read_medians(path: Path | None) -> dict | None:
    """The medians kept at ``path`` as device arrays, or None (none kept, or unreadable)."""
    if path is None or not path.exists():
        return None
    try:
        with np.load(path) as stored:
            return {name: jnp.asarray(stored[name]) for name in stored.files}
    except (OSError, ValueError, KeyError):
        return None


def _write_medians(path: Path | None, params: dict) -> None:
    """Keep ``params`` at ``path`` (atomically); a folder that cannot be written is skipped."""
    if path is None:
        return
    try:
        buffer = io.BytesIO()
        np.savez(buffer, **{name: np.asarray(value) for name, value in params.items()})
        atomic_write_bytes(path, buffer.getvalue())
    except OSError:
        pass


def _drop_op_by_op_programs() -> None:
    """Let JAX free the one-op programs its op-by-op dispatch has compiled (where it can say)."""
    try:
        from jax._src import dispatch
    except ImportError:  # a JAX without this private module: nothing to free
        return
    clear = getattr(getattr(dispatch, "xla_primitive_callable", None), "cache_clear", None)
    if clear is not None:
        clear()


class LaplaceCore(NamedTuple):
    """The fast path's two compiled programs for one data shape (:func:`_laplace_core`).

    ``mode(start, obs, whiten, search)`` gives the mode, the optimiser's outcome (a code:
    :func:`optimiser_outcome`), the whitening W its last BFGS run used and the constrained
    sites at the mode (deterministic sites included). With ``search`` true the mode is searched
    for from the starts of ``MAP_STARTS`` (``start`` is ``flat0``, ``whiten`` unused); false, it
    comes from one BFGS run started at ``start`` in the coordinates ``whiten`` gives: the second
    pass of a fit, whose slip weights move the posterior's width and barely its centre, keeps
    the basin the search found and the whitening of its refinement (a Hessian of every window
    not paid again). ``search`` is a traced flag, so both passes are one program.

    ``laplace(mode, obs, key)`` gives the smallest Hessian eigenvalue at the mode, the scale S
    with S S' = H⁻¹ (eigenvalues floored) and the constrained Laplace draws. The first pass of
    a fit needs none: its slip weights read the residuals at its mode.

    Both are traced once per shape and kept on disk
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
    priors_key: tuple, kind: str, obs_key: tuple, num_draws: int, max_steps: int
) -> LaplaceCore:
    """The MAP search, refit and Laplace draws for one data shape (:class:`LaplaceCore`)."""
    priors = TyrePriors(*priors_key)
    model, template, params = _model_layout(priors_key, kind, obs_key)
    flat0, unravel = ravel_pytree(params)
    hessian_at = _block_hessian(model, template, params)

    def negative_log_posterior(flat, obs):
        return potential_energy(model, (obs,), {}, unravel(flat))

    def whitening_at(flat, obs, scale=1.0):
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
        hessian = scale * hessian_at(lambda f: negative_log_posterior(f, obs), flat)
        finite = jnp.all(jnp.isfinite(hessian))
        eigenvalues, vectors = jnp.linalg.eigh(jnp.where(finite, hessian, jnp.eye(len(flat))))
        return vectors / jnp.sqrt(jnp.maximum(jnp.abs(eigenvalues), 1.0))[None, :]

    def minimise_whitened(flat_start, obs, whiten):
        def rescaled(y, obs):
            return negative_log_posterior(flat_start + whiten @ y, obs)

        solver = optx.BFGS(rtol=BFGS_RTOL, atol=BFGS_ATOL)
        sol = optx.minimise(
            rescaled, solver, jnp.zeros_like(flat_start), args=obs, max_steps=max_steps, throw=False
        )
        return flat_start + whiten @ sol.value, sol.result, whiten

    def minimise_from(flat_start, obs):
        return minimise_whitened(flat_start, obs, whitening_at(flat_start, obs))

    stride = _search_stride(obs_key[0])

    def searched_start(flat_init, obs, _):
        # Several starts on every stride-th window find the basin; the best successful one is
        # refined on all windows (module comment at MAP_STARTS). Returns the refinement's start,
        # its whitening, and the search's outcome code where the search already ended at the
        # mode (on all windows: no refinement), else -1.
        coarse = _every_nth_window(obs, stride)
        starts = jax.vmap(lambda c, m: _start(flat_init, unravel, coarse, priors, c, m))(
            *map(jnp.asarray, zip(*MAP_STARTS, strict=True))
        )
        values, results, whitens = jax.vmap(minimise_from, (0, None))(starts, coarse)
        energies = jax.vmap(negative_log_posterior, (0, None))(values, coarse)
        ok = (results == optx.RESULTS.successful) & jnp.isfinite(energies)
        best = jnp.argmin(jnp.where(ok, energies, jnp.inf))
        best = jnp.where(ok.any(), best, jnp.argmin(jnp.nan_to_num(energies, nan=jnp.inf)))
        mode = values[best]
        if stride == 1:
            return mode, whitens[best], _outcome_code(jax.tree.map(lambda r: r[best], results))
        # The refinement's whitening from the search's windows, scaled to all windows (the
        # prior's curvature scaled with them: only the first steps' lengths depend on it). A
        # Hessian of every window cost about as much as the refinement's BFGS steps together.
        windows = jnp.sum(obs.mask) / jnp.maximum(jnp.sum(coarse.mask), 1)
        return mode, whitening_at(mode, coarse, windows), _NOT_YET

    def given_start(start, obs, whiten):
        return start, whiten, _NOT_YET

    def refined(start, obs, whiten):
        mode, result, whiten = minimise_whitened(start, obs, whiten)
        return mode, _outcome_code(result), whiten

    @jax.jit
    def mode_program(start, obs, whiten, search):
        # One BFGS run on all windows serves both passes (the search's refinement, or the
        # second pass from its given start): the program holds it once, not once per branch.
        start, whiten, code = jax.lax.cond(search, searched_start, given_start, start, obs, whiten)
        mode, code, whiten = jax.lax.cond(
            code >= 0,
            lambda: (start, code, whiten),
            lambda: refined(start, obs, whiten),
        )
        point = constrain_fn(model, (obs,), {}, unravel(mode), return_deterministic=True)
        return mode, code, whiten, point

    @jax.jit
    def laplace_program(mode, obs, key):
        hessian = hessian_at(lambda f: negative_log_posterior(f, obs), mode)
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
        draws = jax.vmap(
            lambda f: constrain_fn(model, (obs,), {}, unravel(f), return_deterministic=True)
        )(z)
        min_eig = jnp.where(finite, eigenvalues.min(), -jnp.inf)
        return min_eig, scale, draws

    key = (priors_key, kind, obs_key, num_draws, max_steps)
    return LaplaceCore(
        mode=stored_program(mode_program, ("tyre-mode-core", *key)),
        laplace=stored_program(laplace_program, ("tyre-laplace-core", *key)),
        flat0=flat0,
    )


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


# The mode program's code for "no outcome yet: the BFGS run on all windows is still to come".
_NOT_YET = np.int32(-1)


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


def _site_plates(model, template: TyreObservations) -> dict[str, tuple[str, ...]]:
    """The plates each site of ``model`` sits in, by site name.

    Read from a trace of the model made while JAX traces it abstractly (no operation runs: run
    op by op on the template, the trace loaded a one-op program for each of its operations).
    """
    plates = {}

    def record(template):
        trace = handlers.trace(handlers.seed(model, 0)).get_trace(template)
        plates.update({k: tuple(f.name for f in v["cond_indep_stack"]) for k, v in trace.items()})
        return 0.0

    with jax.numpy_rank_promotion("allow"):
        jax.make_jaxpr(record)(template)
    return plates


def _block_hessian(model, template: TyreObservations, params: dict):
    """Hessian of a function of the flat parameters, using that drives do not interact.

    The per-drive parameters of one drive meet the windows of that drive only, so the Hessian
    is block-arrow shaped: dense over the global parameters, one block per drive, zero between
    drives. One Hessian-vector product per global parameter gives those columns exactly; one
    product per per-drive *site*, pushing that site in every drive at once, gives each drive's
    block (rows of other drives are zero there), and the global rows of those columns follow
    by symmetry. That is n_global + n_drive_sites products instead of one per parameter: a
    ten-drive fit no longer pays ten times more products on ten times more data.

    Returns ``hessian_at(f, x)`` for ``f`` of the flat vector laid out like ``params``.
    """
    plates = _site_plates(model, template)
    drive_of = {}
    for name, value in params.items():
        in_drive = "drive" in plates[name]
        drive_of[name] = (
            np.broadcast_to(np.arange(template.n_drives), np.shape(value)).astype(float)
            if in_drive
            else np.full(np.shape(value), -1.0)
        )
        if in_drive and np.shape(value) != (template.n_drives,):
            raise ValueError(
                f"site {name!r}: expected shape ({template.n_drives},) in the drive plate, "
                f"got {np.shape(value)}"
            )
    drive = np.asarray(ravel_pytree(drive_of)[0]).astype(int)
    site_of = ravel_pytree({k: np.full(np.shape(v), i) for i, (k, v) in enumerate(params.items())})
    site = np.asarray(site_of[0]).astype(int)
    n = drive.size
    global_idx = np.flatnonzero(drive < 0)
    drive_sites = sorted({int(site[i]) for i in np.flatnonzero(drive >= 0)})
    directions = np.zeros((len(global_idx) + len(drive_sites), n))
    directions[np.arange(len(global_idx)), global_idx] = 1.0
    for k, s in enumerate(drive_sites):
        directions[len(global_idx) + k, site == s] = 1.0
    is_global_row = drive < 0

    def hessian_at(f, x):
        def hvp(v):
            return jax.jvp(jax.grad(f), (x,), (v,))[1]

        products = jax.vmap(hvp)(jnp.asarray(directions, dtype=x.dtype))  # (n_dir, n)
        h = jnp.zeros((n, n), dtype=x.dtype)
        h = h.at[:, global_idx].set(products[: len(global_idx)].T)
        for k, s in enumerate(drive_sites):
            combined = products[len(global_idx) + k]
            for c in np.flatnonzero(site == s):
                same_drive = drive == drive[c]
                column = jnp.where(same_drive, combined, 0.0)
                # Global rows of this column: by symmetry, row c of the global columns.
                column = jnp.where(is_global_row, h[c, :], column)
                h = h.at[:, c].set(column)
        return 0.5 * (h + h.T)

    return hessian_at


def _template_observations(size: int, n_drives: int, surfaces: tuple) -> TyreObservations:
    """Observations of the given shape with harmless values (for tracing only)."""
    zeros = jnp.zeros(size)
    return TyreObservations(
        slip=zeros,
        rho=zeros,
        slip_sd=jnp.ones(size),
        rho_sd=jnp.ones(size),
        temperature_c=jnp.full(size, 20.0),
        load_change=zeros,
        neighbour_slip=zeros,
        slip_weight=jnp.ones(size),
        imu_gain_log_sd=zeros,
        rho_score=zeros,
        rho_score_slope=zeros,
        at_limit=jnp.zeros(size, dtype=bool),
        drive_index=jnp.zeros(size, dtype=int),
        block_index=jnp.zeros(size, dtype=int),
        surface_index=jnp.zeros(size, dtype=int),
        mask=jnp.ones(size, dtype=bool),
        n_drives=n_drives,
        surfaces=surfaces,
    )
