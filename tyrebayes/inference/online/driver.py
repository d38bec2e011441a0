"""Running the in-car estimator over streams: compiled, one car or many, from the type prior.

:func:`run_online` and :func:`run_online_cars` are :meth:`~.estimator.OnlineEstimator.run`
compiled with :data:`COMPILER_OPTIONS` (for one car; vmapped over many), :func:`online_estimate`
the command's path: an estimator from the type prior over one stream's steps. Each gives an
:class:`~.run.OnlineRun`.
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax

from ...internal.renamed import renamed_keyword
from ..tyre.model import TyrePriors
from .config import OnlineConfig
from .estimator import OnlineEstimator
from .run import OnlineRun
from .state import FilterState
from .windows import WindowBlocks

#: XLA options the estimator's compiled runs use: XLA's fast math, with NaN, infinities, IEEE
#: division and the library's functions kept as they are. What it leaves on is reassociation,
#: fused multiply-add and the sign of zero: round-off only, so the filter's finiteness checks and
#: safeguards work as written. A Magic Formula car-hour ran 1.07x faster with them, its final
#: mean within 3e-10 posterior sds of the default compilation's, with the same alarms and flags
#: (``benchmarks/results/online_speed.json``, ``compiler_options``); a test compares the two on
#: a linear-model stream.
COMPILER_OPTIONS = {
    "xla_cpu_enable_fast_math": True,
    "xla_cpu_fast_math_honor_nans": True,
    "xla_cpu_fast_math_honor_infs": True,
    "xla_cpu_fast_math_honor_division": True,
    "xla_cpu_fast_math_honor_functions": True,
}


@functools.partial(eqx.filter_jit, compiler_options=COMPILER_OPTIONS)
def run_online(estimator: OnlineEstimator, state: FilterState, blocks: WindowBlocks) -> OnlineRun:
    """:meth:`OnlineEstimator.run`, compiled with :data:`COMPILER_OPTIONS` (once per block shape
    and estimator settings)."""
    return estimator.run(state, blocks)


@functools.partial(eqx.filter_jit, compiler_options=COMPILER_OPTIONS)
def run_online_cars(
    estimator: OnlineEstimator, states: FilterState, blocks: WindowBlocks
) -> OnlineRun:
    """:meth:`OnlineEstimator.run` over many cars in one compiled call: ``states`` and ``blocks``
    carry a leading car axis (vmapped), the trajectory a car axis before its time axis."""
    return jax.vmap(estimator.run)(states, blocks)


@renamed_keyword("kind", "model", what="the tyre-curve model")
def online_estimate(
    blocks: WindowBlocks,
    *,
    model: str = "magic",
    priors: TyrePriors | None = None,
    config: OnlineConfig | None = None,
    imu_gain_log_sd: float = 0.0,
) -> OnlineRun:
    """Run the estimator from the type prior over one stream's blocks (the command's path).

    Parameters
    ----------
    blocks : WindowBlocks
        The stream's steps (:func:`~.stream.stream_steps`); their surface sets μ_max's prior.
    model : str
        The tyre-curve model (:data:`~tyrebayes.inference.tyre.curves.CURVE_MODELS`).
    priors : TyrePriors, optional
        The batch model's prior scales (default :class:`TyrePriors`).
    config : OnlineConfig, optional
        Drift, Newton steps, change detection, readiness (default :func:`~.config.default_config`).
    imu_gain_log_sd : float
        Prior sd of the IMU's log gain (0: the gain is known).

    Returns
    -------
    OnlineRun
        The final filter state and the trajectory of summaries, one per step; its ``to_dict()``
        is the estimator's part of ``tyrebayes online --json``.

    Examples
    --------
    The shipped one-minute segment in two steps; the filter's first compilation takes longer
    than a doctest should, so that line is not run here (``tyrebayes online`` runs it):

    >>> from tyrebayes import load_vehicle
    >>> from tyrebayes._resources import data_dir
    >>> from tyrebayes.inference.online import stream_steps, stream_windows
    >>> path = data_dir() / "comma2k19_rav4_segment.csv"
    >>> blocks = stream_steps(stream_windows(path, load_vehicle("suv_rav4")))
    >>> blocks.slip.shape[0], blocks.surface
    (2, 'dry')
    >>> run = online_estimate(blocks)  # doctest: +SKIP
    >>> run.to_dict()["final"]["enough_evidence"]  # doctest: +SKIP
    False
    """
    estimator = OnlineEstimator.create(
        model=model,
        surface=blocks.surface,
        priors=priors,
        config=config,
        imu_gain_log_sd=imu_gain_log_sd,
    )
    return run_online(estimator, estimator.init(), blocks)


__all__ = [
    "COMPILER_OPTIONS",
    "online_estimate",
    "run_online",
    "run_online_cars",
]
