"""The estimate of the online estimator's state: the moments a summary reads, and the summary.

A state's summary needs θ's covariance only through a few moments (:class:`~.summary.StateMoments`:
θ's mean and sds, log C_x's mean and sd at the mean tyre temperature since the (re)start), so a
trajectory keeps those per step and summarises every step at once after the scan
(:meth:`~.estimator.OnlineEstimator.run`). The summary (:func:`summary_of`) adds the readiness
of C_x, the prior-conflict check and μ_max's surface-label check (:mod:`.summary`).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..tyre.adequacy import likelier_surface
from ..tyre.model import SURFACES, TyrePriors
from .config import OnlineConfig
from .inflation import inflation_in_use
from .parameters import PRIOR_CHECKED, GaussianPrior
from .state import FilterState
from .summary import (
    OnlineSummary,
    StateMoments,
    c_x_direction,
    joint_prior_sds,
    log_normal_summary,
    readiness,
)


def state_moments(state: FilterState, index: dict[str, int], config: OnlineConfig) -> StateMoments:
    """What :func:`summary_of` reads of a state: the part of a summary that needs θ's
    covariance, and the counters (``index``: θ's coordinates by name)."""
    mean_temperature = jnp.where(
        state.n_slip_windows > 0,
        state.temperature_sum / jnp.maximum(state.n_slip_windows, 1.0),
        20.0,
    )
    a = c_x_direction(state.mean.shape[0], mean_temperature, index, state.mean.dtype)
    return StateMoments(
        time_s=state.time_s,
        mean=state.mean,
        sd=jnp.sqrt(jnp.diag(state.cov)),
        log_c_x_mean=a @ state.mean,
        log_c_x_sd=jnp.sqrt(a @ state.cov @ a),
        n_slip_windows=state.n_slip_windows,
        n_excited_windows=state.n_excited_windows,
        n_limit_windows=state.n_limit_windows,
        alarm=state.alarm,
        swap_alarm=state.swap_alarm,
        n_alarms=state.n_alarms,
        log_bayes_factor=state.log_bayes_factor,
        slip_inflation=inflation_in_use(
            state.inflation, config.initial_inflation, config.inflation_prior_blocks
        ),
    )


def summary_of(
    moments: StateMoments, prior: GaussianPrior, priors: TyrePriors, config: OnlineConfig
) -> OnlineSummary:
    """The estimate from a state's :func:`state_moments` (unbatched; vmap for many), against
    the type prior ``prior`` and the batch model's prior scales ``priors``."""
    idx = {n: i for i, n in enumerate(prior.names)}
    sd = moments.sd
    c_x = log_normal_summary(moments.log_c_x_mean, moments.log_c_x_sd)
    gain_i, offset_i, c_i = idx["log_force_gain"], idx["slip_offset"], idx["log_c_xr"]
    prior_sds = (moments.mean - prior.mean) / jnp.sqrt(jnp.diag(prior.cov))
    prior_z = prior_sds[c_i]
    checked = jnp.asarray([n in PRIOR_CHECKED for n in prior.names])
    checked_sds = jnp.where(checked, prior_sds, 0.0)
    worst = jnp.argmax(jnp.abs(checked_sds))
    rows = np.asarray([i for i, n in enumerate(prior.names) if n in PRIOR_CHECKED])
    joint = joint_prior_sds((moments.mean - prior.mean)[rows], prior.cov[np.ix_(rows, rows)])
    conflict = (jnp.abs(checked_sds[worst]) > config.max_prior_z) | (joint > config.max_prior_z)
    ready, reason = readiness(
        c_x, moments.n_slip_windows, moments.n_excited_windows, prior_z, config, conflict
    )
    mu_i = idx["log_mu_max"]
    mu_contraction = 1.0 - sd[mu_i] / jnp.sqrt(prior.cov[mu_i, mu_i])
    mu_observed = (moments.n_limit_windows > 0) & (mu_contraction >= config.mu_observed_contraction)
    mu_prior_z = prior_sds[mu_i]
    likelier, label_log_bf = likelier_surface(
        moments.mean[mu_i],
        sd[mu_i],
        prior.surface,
        SURFACES,
        jnp.log(priors.mu_median(SURFACES)),
        priors.mu_log_sd(SURFACES),
    )
    return OnlineSummary(
        time_s=moments.time_s,
        c_x=c_x,
        c_xr=log_normal_summary(moments.mean[c_i], sd[c_i]),
        mu_max=log_normal_summary(moments.mean[mu_i], sd[mu_i]),
        force_gain=log_normal_summary(moments.mean[gain_i], sd[gain_i]),
        slip_offset_mean=moments.mean[offset_i],
        slip_offset_sd=sd[offset_i],
        ready=ready,
        reason=reason,
        mu_observed=mu_observed,
        mu_prior_z=mu_prior_z,
        mu_likelier_surface=likelier.astype(jnp.int32),
        mu_label_log_bf=label_log_bf,
        alarm=moments.alarm,
        swap_alarm=moments.swap_alarm,
        n_alarms=moments.n_alarms,
        swap_log_bayes_factor=moments.log_bayes_factor,
        n_slip_windows=moments.n_slip_windows,
        n_excited_windows=moments.n_excited_windows,
        n_limit_windows=moments.n_limit_windows,
        slip_inflation=moments.slip_inflation,
        prior_conflict=conflict,
        conflict_prior_sds=checked_sds[worst],
        conflict_joint_prior_sds=joint,
        conflict_coordinate=worst.astype(jnp.int32),
        coordinate_names=prior.names,
    )


__all__ = ["state_moments", "summary_of"]
