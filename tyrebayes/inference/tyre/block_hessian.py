"""The Laplace approximation's Hessian in block-arrow form: drives do not interact.

Used by :mod:`tyrebayes.inference.tyre.laplace`.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from numpyro import handlers

from .data import TyreObservations


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


def _ravel(tree) -> np.ndarray:
    """``ravel_pytree(tree)[0]`` of a tree of NumPy arrays, in NumPy: the same order (its
    leaves'), without an eager JAX program per shape."""
    return np.concatenate([np.ravel(leaf) for leaf in jax.tree.leaves(tree)])


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
    drive = _ravel(drive_of).astype(int)
    site = _ravel({k: np.full(np.shape(v), i) for i, (k, v) in enumerate(params.items())})
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
