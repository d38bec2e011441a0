"""Readiness: what the estimator withholds, and why; and a μ_max its surface label contradicts."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import pytest

from tyrebayes.inference.online import OnlineEstimator
from tyrebayes.inference.online.config import default_config
from tyrebayes.inference.online.parameters import PRIOR_CHECKED
from tyrebayes.inference.online.summary import (
    INTERVAL_TOO_WIDE,
    OUTSIDE_TYPE,
    PRIOR_CONFLICT,
    READY,
    TOO_LITTLE_EXCITATION,
    OnlineSummary,
    joint_prior_sds,
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
    c_x = log_normal_summary(jnp.log(30.0), jnp.asarray(0.02))
    conflict = readiness(c_x, 1000.0, 1000.0, jnp.asarray(0.5), CONFIG, jnp.asarray(True))
    assert (bool(conflict[0]), int(conflict[1])) == (False, PRIOR_CONFLICT)


def _summary(
    mu_observed: bool, mu_prior_z: float, conflict: bool = False, label_log_bf: float = -2.0
) -> OnlineSummary:
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
        mu_likelier_surface=jnp.asarray(3),
        mu_label_log_bf=jnp.asarray(label_log_bf),
        alarm=jnp.asarray(False),
        swap_alarm=jnp.asarray(False),
        n_alarms=jnp.asarray(0),
        swap_log_bayes_factor=zero,
        n_slip_windows=jnp.asarray(1000.0),
        n_excited_windows=jnp.asarray(800.0),
        n_limit_windows=jnp.asarray(12.0),
        slip_inflation=one,
        prior_conflict=jnp.asarray(conflict),
        conflict_prior_sds=jnp.asarray(5.3 if conflict else 0.4),
        conflict_joint_prior_sds=jnp.asarray(4.9 if conflict else 0.3),
        conflict_coordinate=jnp.asarray(1),
        coordinate_names=("log_c_xr", "abs_force_ratio"),
    )


def test_an_observed_mu_max_far_from_its_surface_prior_questions_the_label():
    far = _summary(True, 5.0).to_dict()
    assert far["mu_max"] is not None and far["mu_max_prior_sds"] == 5.0
    assert far["mu_max_note"].startswith("+5.0 prior sds from the surface's median")
    assert _summary(True, -2.7).to_dict()["mu_max_note"] is None
    # Not observed: the value is the prior's, and says nothing of the label.
    assert _summary(False, 5.0).to_dict()["mu_max_note"] is None


def test_a_tyre_coordinate_in_conflict_with_its_prior_withholds_c_x_and_mu_max():
    record = _summary(True, 2.7, conflict=True).to_dict()
    assert record["mu_max"] is None and record["mu_max_reason"].startswith("withheld: ")
    assert record["prior_conflict"] == {
        "coordinate": "abs_force_ratio",
        "prior_sds": 5.3,
        "joint_prior_sds": pytest.approx(4.9),
    }
    assert _summary(True, 2.7).to_dict()["prior_conflict"] is None


def _excited_prior_state():
    """A Magic Formula estimator and its prior state with windows enough to be ready."""
    estimator = OnlineEstimator.create(model="magic")
    many = jnp.asarray(1000.0)
    state = eqx.tree_at(
        lambda s: (s.n_slip_windows, s.n_excited_windows), estimator.init(), (many, many)
    )
    return estimator, state


@pytest.mark.parametrize("coordinate", ["abs_force_ratio", "log_curve_curvature_gap"])
def test_the_summary_names_the_checked_coordinate_beyond_the_readiness_distance(coordinate):
    estimator, state = _excited_prior_state()
    names = estimator.prior.names
    limit = float(estimator.config.max_prior_z)

    def moved(name, sds):
        j = names.index(name)
        step = sds * jnp.sqrt(estimator.prior.cov[j, j])
        return estimator.summary(eqx.tree_at(lambda s: s.mean, state, state.mean.at[j].add(step)))

    assert coordinate in PRIOR_CHECKED
    assert not bool(estimator.summary(state).prior_conflict)
    far = moved(coordinate, -(limit + 1.0))
    assert bool(far.prior_conflict) and int(far.reason) == PRIOR_CONFLICT
    assert far.coordinate_names[int(far.conflict_coordinate)] == coordinate
    assert float(far.conflict_prior_sds) == pytest.approx(-(limit + 1.0))
    # C_xr has its own rule (OUTSIDE_TYPE); the noise scales are the sensors', not the tyre's.
    assert int(moved("log_c_xr", limit + 1.0).reason) == OUTSIDE_TYPE
    assert not bool(moved("log_c_xr", limit + 1.0).prior_conflict)
    assert not bool(moved("log_rho_noise_scale", limit + 1.0).prior_conflict)


def test_joint_prior_sds_is_one_coordinates_distance_for_one_and_grows_with_more():
    cov = jnp.diag(jnp.asarray([4.0, 0.25, 1.0]))
    one = joint_prior_sds(jnp.asarray([-3.0]), cov[:1, :1])
    assert float(one) == pytest.approx(1.5, rel=1e-9)
    # Three coordinates at 3 sds each: d² = 27, χ²₃ tail 5.9e-6, as far out as one coordinate
    # at 4.53 sds.
    three = joint_prior_sds(jnp.asarray([6.0, 1.5, 3.0]), cov)
    assert float(three) == pytest.approx(4.530, abs=1e-3)
    # One coordinate at 3 sds among three: nearer than 3 sds alone (two of them sit at 0).
    assert float(joint_prior_sds(jnp.asarray([6.0, 0.0, 0.0]), cov)) < 3.0


def test_coordinates_each_inside_but_together_beyond_the_distance_are_a_conflict():
    estimator, state = _excited_prior_state()
    names = estimator.prior.names
    limit = float(estimator.config.max_prior_z)
    shifted = state.mean
    for name in (n for n in names if n in PRIOR_CHECKED):
        j = names.index(name)
        shifted = shifted.at[j].add(0.85 * limit * jnp.sqrt(estimator.prior.cov[j, j]))
    summary = estimator.summary(eqx.tree_at(lambda s: s.mean, state, shifted))
    assert abs(float(summary.conflict_prior_sds)) == pytest.approx(0.85 * limit)
    assert float(summary.conflict_joint_prior_sds) > limit
    assert bool(summary.prior_conflict) and int(summary.reason) == PRIOR_CONFLICT
    assert summary.to_dict()["prior_conflict"]["joint_prior_sds"] > limit


def test_an_observed_mu_max_likelier_on_another_surface_questions_the_label():
    record = _summary(True, 2.7, label_log_bf=4.4).to_dict()
    assert record["mu_max_likelier_surface"] == "dry"
    assert record["mu_max_note"] == (
        "81 times likelier under the dry prior (Bayes factor beyond 20): check the drive's "
        "surface label"
    )
    assert _summary(True, 2.7, label_log_bf=2.0).to_dict()["mu_max_note"] is None
    assert _summary(False, 2.7, label_log_bf=4.4).to_dict()["mu_max_note"] is None
