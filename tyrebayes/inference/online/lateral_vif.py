"""The variance inflation of the online lateral estimator's two equations.

The batch fit weights each equation by 1/VIF of its residuals
(:func:`~tyrebayes.inference.lateral.inflation.residual_inflation`): the largest of the AR(1)
factor and the batch-means factors at 10, 30 and 60 s (each once :data:`MIN_CHUNKS` batches
are in; batches on the clock, those at least half valid). Online, the same factors come from
the equation's moments (:class:`~.lateral_statistics.EquationMoments`) at the current
coefficients: every residual sum they need is a linear or quadratic form of the coefficients,
so the VIF is that of all the data so far at the current estimate, as the batch fit's is at its
own. Over the first minute and a half it is blended with :data:`INITIAL_VIF`. On real roads the
slow batches dominate (road bank, a corner the linear range misfits) and need minutes of data
to show; until both equations have seen :data:`MIN_CHUNKS` batches of 30 s nothing is reported
(:func:`settled`).
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from .lateral_statistics import CHUNK, EquationMoments

#: VIF assumed before the residuals say: low-passed at 2 Hz and read at 10 Hz, white noise alone
#: gives an AR(1) factor near 4, and road bank and a curve that misfits over a corner add to it;
#: 10 keeps the first blocks' intervals on the wide side.
INITIAL_VIF = 10.0
#: Weight of :data:`INITIAL_VIF` against the estimate, in 10 s chunks.
VIF_PRIOR_CHUNKS = 8.0
#: Batches a length needs to count (the batch fit's ``MIN_BATCHES``).
MIN_CHUNKS = 8


def inflation(
    moments: EquationMoments, coefficients: Float[Array, " q"], sizes: Float[Array, "3"]
) -> Float[Array, ""]:
    """The VIF in use for residuals e = z · ``coefficients`` (module docstring); ``sizes`` are
    the three batch lengths in samples.

    Examples
    --------
    >>> import numpy as np
    >>> from tyrebayes.inference.online.lateral_statistics import equation_moments
    >>> e = np.random.default_rng(0).normal(size=(20, 300, 1))
    >>> mom = equation_moments(jnp.asarray(e), jnp.ones((20, 300), bool))
    >>> total = mom.block(0)
    >>> for i in range(1, 20):
    ...     total = total.plus(mom.block(i))
    >>> 1.0 < float(inflation(total, jnp.ones(1), jnp.asarray([100.0, 300.0, 600.0]))) < 3.0
    True
    """
    c = coefficients
    n = jnp.maximum(moments.count, 1.0)
    centre = moments.total @ c / n
    var = jnp.maximum(c @ moments.gram @ c / n - centre**2, 1e-30)
    phi = jnp.clip((c @ moments.lagged @ c / n - centre**2) / var, 0.0, 0.995)
    ar1 = (1.0 + phi) / (1.0 - phi)
    batches = jnp.maximum(moments.batches, 1.0)
    means = moments.batch_total @ c / batches
    squares = jnp.einsum("i,lij,j->l", c, moments.batch_gram, c) / batches
    batch_var = squares - means**2
    factors = jnp.where(moments.batches >= MIN_CHUNKS, sizes * batch_var / var, 1.0)
    estimate = jnp.where(
        moments.count >= 20, jnp.maximum(jnp.maximum(ar1, jnp.max(factors)), 1.0), 1.0
    )
    seen = moments.count / CHUNK
    return (VIF_PRIOR_CHUNKS * INITIAL_VIF + seen * estimate) / (VIF_PRIOR_CHUNKS + seen)


def settled(batches_30s: Float[Array, " equations"]) -> Bool[Array, ""]:
    """Whether every equation has seen :data:`MIN_CHUNKS` batches of a block's length (30 s):
    before that the slow correlations that dominate on real roads are not measured, and the
    intervals, however narrow, are not yet trusted (readiness waits for it)."""
    return jnp.all(batches_30s >= MIN_CHUNKS)


__all__ = ["INITIAL_VIF", "MIN_CHUNKS", "VIF_PRIOR_CHUNKS", "inflation", "settled"]
