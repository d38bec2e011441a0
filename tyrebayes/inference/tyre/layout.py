"""The per-tyre model's parameter layout for one data shape, and its medians kept on disk.

The layout (numpyro's initialisation at the prior medians) fixes the flat parameter vector that
the Laplace core (:mod:`tyrebayes.inference.tyre.laplace`) and the NUTS runner share.
"""

from __future__ import annotations

import functools
import io
from functools import partial
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from numpyro.infer import init_to_median
from numpyro.infer.util import initialize_model

from ..._io import atomic_write_bytes
from ...internal.stored_program import kept_file
from .data import TyreObservations
from .model import TyrePriors, tyre_model


def _model_layout(priors_key: tuple, model: str, obs_key: tuple):
    """The NumPyro model for one data shape, a template of that shape and its median parameters.

    Returns ``(numpyro_model, template, params)``; ``params`` are unconstrained, keyed by site,
    and fix the flat layout (``ravel_pytree``) that the Laplace core and the NUTS runner share.
    They depend on the drives and surfaces, not on the number of windows: the model has no latent
    per-window site, and ``init_to_median`` draws from the priors only. The template therefore
    has :data:`LAYOUT_WINDOWS` windows whatever the data's length, so that the layout (numpyro's
    initialisation, run op by op: seconds, and memory a fleet worker keeps) is made once per
    number of drives and surfaces, not once per padded length.
    """
    _, n_drives, surfaces = obs_key
    return _layout(priors_key, model, n_drives, surfaces)


# Windows of the template :func:`_model_layout` traces the model on (any length gives the same
# parameters; tests/inference/tyre/test_laplace.py checks it).
LAYOUT_WINDOWS = 256


@functools.lru_cache(maxsize=16)
def _layout(priors_key: tuple, model: str, n_drives: int, surfaces: tuple):
    numpyro_model = partial(tyre_model, priors=TyrePriors(*priors_key), model=model)
    template = _template_observations(LAYOUT_WINDOWS, n_drives, surfaces)
    stored = _stored_medians_path((priors_key, model, n_drives, surfaces))
    params = _read_medians(stored)
    if params is not None:
        return numpyro_model, template, params

    # init_to_median draws a batch of prior samples; numpyro broadcasts it by rank promotion.
    with jax.numpy_rank_promotion("allow"):
        init = initialize_model(
            jax.random.PRNGKey(0),
            numpyro_model,
            model_args=(template,),
            init_strategy=init_to_median,
        )
    # Run op by op, the initialisation compiled a one-op program for each of its few hundred
    # operations, which stay loaded under every later fit's peak; they are not needed again.
    # Compiled as one program instead, the medians moved by round-off, and fits started from
    # them moved far more than that on the external drives (the MAP search is sensitive to its
    # start): left op by op, the results stay as they were.
    _drop_op_by_op_programs()
    params = init.param_info.z
    _write_medians(stored, params)
    return numpyro_model, template, params


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
