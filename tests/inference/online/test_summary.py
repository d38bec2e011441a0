"""Readiness: what the estimator withholds, and why."""

from __future__ import annotations

import jax.numpy as jnp

from tyrebayes.inference.online.config import default_config
from tyrebayes.inference.online.summary import (
    INTERVAL_TOO_WIDE,
    OUTSIDE_TYPE,
    READY,
    TOO_LITTLE_EXCITATION,
    log_normal_summary,
    readiness,
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
