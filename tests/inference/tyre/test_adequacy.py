"""Model adequacy as data: the checks fire on what the model cannot describe, not on clean data."""

import numpy as np
import pytest

from tyrebayes.inference.tyre.adequacy import (
    EXCITATION_FORCE,
    MAX_LABEL_LOG_BAYES_FACTOR,
    MAX_MU_PRIOR_SDS,
    MAX_STEP_T,
    MIN_EXCITED_WINDOWS,
    Adequacy,
    assess_adequacy,
    label_in_doubt,
    likelier_surface,
    offset_step,
)


def _clean(seed=0, n=2000):
    rng = np.random.default_rng(seed)
    return rng.normal(size=n), rng.uniform(0.0, 0.3, n), np.zeros(n, dtype=int)


def test_clean_residuals_are_adequate():
    z, rho, drive = _clean()
    offsets = (np.random.default_rng(1).normal(0.0, 1e-4, 100),)
    result = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, block_offsets=offsets)
    assert result.adequate, result.reasons
    assert result.reasons == ()


def test_each_check_fires_with_its_reason():
    z, rho, drive = _clean()
    wide = assess_adequacy(3.0 * z, rho, drive, 1, shape_prior_sds={})
    assert not wide.adequate and "predictive band" in wide.reasons[0]
    trend = assess_adequacy(z + 40.0 * (rho - 0.15), rho, drive, 1, shape_prior_sds={})
    assert any("trend with the force" in r for r in trend.reasons)
    drift = assess_adequacy(
        z + np.repeat(np.random.default_rng(2).normal(0, 1.5, 50), 40),
        rho,
        drive,
        1,
        shape_prior_sds={},
    )
    assert any("variance inflation" in r for r in drift.reasons)
    edge = assess_adequacy(z, rho, drive, 1, shape_prior_sds={"shape C": -3.0})
    assert any("shape C" in r for r in edge.reasons)
    nan = assess_adequacy(
        np.where(np.arange(z.size) == 5, np.nan, z), rho, drive, 1, shape_prior_sds={}
    )
    assert not nan.adequate and "non-finite" in nan.reasons[0]


def test_offset_step_statistic():
    rng = np.random.default_rng(3)
    steady = rng.normal(0.0, 1e-4, 120)
    assert offset_step(steady)[0] < MAX_STEP_T
    stepped = steady + np.where(np.arange(120) >= 60, 2e-3, 0.0)
    t, size = offset_step(stepped)
    assert t > 3 * MAX_STEP_T and size == pytest.approx(2e-3, rel=0.1)
    assert offset_step(steady[:5]) == (0.0, 0.0)
    _, _, drive = _clean()
    z, rho, _ = _clean()
    jumped = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, block_offsets=(stepped,))
    assert any("steps by 0.002" in r for r in jumped.reasons), jumped.reasons
    # A drift of the same t but tiny size is not a change of tyre.
    small = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, block_offsets=(stepped / 10,))
    assert small.adequate, small.reasons


def test_a_drive_without_excitation_does_not_measure_c_x():
    z, rho, drive = _clean()
    cruise = assess_adequacy(
        z, 0.9 * EXCITATION_FORCE * (2 * rho / 0.3 - 1), drive, 1, shape_prior_sds={}
    )
    assert cruise.excited_windows == 0
    assert not cruise.adequate and "too little excitation: 0 slip windows" in cruise.reasons[0]
    assert not cruise.measures_c_x
    # The count is of windows at or beyond the force, either sign: braking windows excite too.
    few = np.where(np.arange(z.size) < MIN_EXCITED_WINDOWS, -EXCITATION_FORCE, 0.01)
    enough = assess_adequacy(z, few, drive, 1, shape_prior_sds={})
    assert enough.excited_windows == MIN_EXCITED_WINDOWS
    assert not any("excitation" in r for r in enough.reasons), enough.reasons
    assert enough.measures_c_x


def test_c_xr_far_from_the_type_prior_is_flagged():
    z, rho, drive = _clean()
    far = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, c_xr_prior_sds=7.1)
    assert not far.adequate and "C_xr +7.1 prior sds" in far.reasons[0]
    assert not far.measures_c_x
    # Inadequate for another reason, it still measured C_x.
    wide = assess_adequacy(3.0 * z, rho, drive, 1, shape_prior_sds={}, c_xr_prior_sds=0.2)
    assert not wide.adequate and wide.measures_c_x
    near = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, c_xr_prior_sds=-3.9)
    assert near.adequate, near.reasons
    assert near.c_xr_prior_sds == -3.9


def test_a_record_saved_without_the_identification_fields_reads_back():
    old = {
        "adequate": True,
        "reasons": [],
        "variance_inflation": 1.2,
        "outside_90": 0.1,
        "trend_t": 0.3,
        "step_t": 1.0,
    }
    record = Adequacy.from_dict(old)
    assert record.excited_windows is None and np.isnan(record.c_xr_prior_sds)
    assert record.measures_c_x  # nothing says otherwise
    z, rho, drive = _clean()
    new = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, c_xr_prior_sds=0.5)
    assert Adequacy.from_dict(new.as_dict()) == new


def test_mu_max_far_from_its_surface_prior_questions_the_label():
    z, rho, drive = _clean()
    ice = assess_adequacy(
        z, rho, drive, 1, shape_prior_sds={}, mu_prior_sds={"ice": 5.0, "dry": -0.3}
    )
    assert ice.reasons == (
        f"mu_max on ice +5.0 prior sds from that surface's median (beyond {MAX_MU_PRIOR_SDS:g}): "
        "check the drive's surface label",
    )
    assert ice.measures_c_x  # the label is in doubt, not the stiffness
    assert Adequacy.from_dict(ice.as_dict()) == ice
    plausible = assess_adequacy(z, rho, drive, 1, shape_prior_sds={}, mu_prior_sds={"snow": 2.7})
    assert plausible.adequate, plausible.reasons


def test_mu_max_likelier_under_another_surface_questions_the_label():
    z, rho, drive = _clean()
    snow = assess_adequacy(
        z, rho, drive, 1, shape_prior_sds={}, mu_prior_sds={"snow": 2.7},
        mu_likelier_surface={"snow": ("dry", 4.4)},
    )  # fmt: skip
    assert snow.reasons == (
        "mu_max on snow 81 times likelier under the dry prior than under snow's (Bayes factor "
        "beyond 20): check the drive's surface label",
    )
    assert Adequacy.from_dict(snow.as_dict()) == snow
    assert label_in_doubt(2.7, 4.4) and label_in_doubt(5.0, -9.0)
    assert not label_in_doubt(2.7, np.log(19.0)) and not label_in_doubt(float("nan"), np.nan)
    # One reason per surface: beyond 4 sds the distance rule has said it.
    far = assess_adequacy(
        z, rho, drive, 1, shape_prior_sds={}, mu_prior_sds={"ice": 5.0},
        mu_likelier_surface={"ice": ("snow", 9.0)},
    )  # fmt: skip
    assert len(far.reasons) == 1 and "prior sds" in far.reasons[0]


def test_likelier_surface_is_the_prior_predictive_ratio():
    surfaces = ("snow", "ice", "wet", "dry")
    medians, sds = np.log([0.35, 0.12, 0.75, 1.0]), np.array([0.35, 0.4, 0.2, 0.15])
    best, lbf = likelier_surface(np.log(0.91), 0.03, "snow", surfaces, medians, sds)
    scale = np.hypot(sds, 0.03)
    density = -0.5 * ((np.log(0.91) - medians) / scale) ** 2 - np.log(scale)
    assert surfaces[int(best)] == "dry"
    assert float(lbf) == pytest.approx(density[3] - density[0], rel=1e-5)
    # Only grippier surfaces are weighed: none is grippier than dry.
    best, own = likelier_surface(np.log(0.6), 0.03, "dry", surfaces, medians, sds)
    assert surfaces[int(best)] == "dry" and float(own) == -np.inf
    # A summer tyre on snow at 0.13: the ice prior predicts it more than 20 times better than
    # the snow one, but a low μ_max may be the tyre's; against the grippier surfaces the label
    # holds.
    density = -0.5 * ((np.log(0.13) - medians) / scale) ** 2 - np.log(scale)
    assert density[1] - density[0] > MAX_LABEL_LOG_BAYES_FACTOR
    best, low = likelier_surface(np.log(0.13), 0.03, "snow", surfaces, medians, sds)
    assert surfaces[int(best)] == "wet" and float(low) < -10
