"""Readiness: what the estimator withholds, and why; and a μ_max its surface label contradicts."""

from __future__ import annotations

import jax.numpy as jnp

from tyrebayes.inference.online.config import default_config
from tyrebayes.inference.online.summary import (
    INTERVAL_TOO_WIDE,
    OUTSIDE_TYPE,
    READY,
    TOO_LITTLE_EXCITATION,
    OnlineSummary,
    log_normal_summary,
    readiness,
    summary_record,
)

CONFIG = default_config("magic")


def _reason(log_sd, n_slip, prior_z):
    c_x = log_normal_summary(jnp.log(30.0), jnp.asarray(log_sd))
    ready, reason = readiness(c_x, n_slip, n_slip, jnp.asarray(prior_z), CONFIG)
    return bool(ready), int(reason)


def test_a_narrow_well_excited_typical_estimate_is_ready():
    assert _reason(0.02, 1000.0, 0.5) == (True, READY)


def test_each_missing_condition_withholds_with_its_reason():
    assert _reason(0.02, 10.0, 0.5) == (False, TOO_LITTLE_EXCITATION)
    assert _reason(0.2, 1000.0, 0.5) == (False, INTERVAL_TOO_WIDE)
    # A narrow interval far outside the type's range: the model does not fit, so no value.
    assert _reason(0.001, 1000.0, -9.0) == (False, OUTSIDE_TYPE)


def _summary(mu_observed: bool, mu_prior_z: float) -> OnlineSummary:
    value = log_normal_summary(jnp.log(0.9), jnp.asarray(0.02))
    zero, one = jnp.asarray(0.0), jnp.asarray(1.0)
    return OnlineSummary(
        time_s=jnp.asarray(600.0),
        c_x=value,
        c_xr=value,
        mu_max=value,
        force_gain=value,
        slip_offset_mean=zero,
        slip_offset_sd=one,
        ready=jnp.asarray(True),
        reason=jnp.asarray(READY),
        mu_observed=jnp.asarray(mu_observed),
        mu_prior_z=jnp.asarray(mu_prior_z),
        alarm=jnp.asarray(False),
        n_alarms=jnp.asarray(0),
        swap_log_bayes_factor=zero,
        n_slip_windows=jnp.asarray(1000.0),
        n_excited_windows=jnp.asarray(800.0),
        n_limit_windows=jnp.asarray(12.0),
        slip_inflation=one,
    )


def test_an_observed_mu_max_far_from_its_surface_prior_questions_the_label():
    far = summary_record(_summary(True, 5.0))
    assert far["mu_max"] is not None and far["mu_max_prior_sds"] == 5.0
    assert far["mu_max_note"].startswith("+5.0 prior sds from the surface's median")
    assert summary_record(_summary(True, -2.7))["mu_max_note"] is None
    # Not observed: the value is the prior's, and says nothing of the label.
    assert summary_record(_summary(False, 5.0))["mu_max_note"] is None
