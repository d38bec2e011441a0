"""The curve-shape prior comes from the shipped database of measured tyres, not from a guess."""

import numpy as np
import pytest

from tyrebayes._tyre_curve_sets import distinct_passenger_sets, load_tyre_curve_sets
from tyrebayes.inference.tyre.curve_prior import curve_shape_prior
from tyrebayes.inference.tyre.model import TyrePriors


def test_database_ships_no_gpl_rows_and_keeps_sources():
    table = load_tyre_curve_sets()
    assert not table["licence"].str.contains("GPL").any()
    for column in ("source_repo", "path", "commit", "licence"):
        assert table[column].notna().all(), column


def test_tyre_priors_match_the_derivation():
    prior = curve_shape_prior()
    assert prior.n_sets == len(distinct_passenger_sets()) == 9
    defaults = TyrePriors()
    # TyrePriors holds the derived numbers rounded to 3 decimals.
    for field, value in (
        ("curve_shape_excess_log_mean", prior.shape_excess_log_mean),
        ("curve_shape_excess_log_sd", prior.shape_excess_log_sd),
        ("curve_curvature_log_mean", prior.curvature_log_mean),
        ("curve_curvature_log_sd", prior.curvature_log_sd),
    ):
        assert getattr(defaults, field) == pytest.approx(value, abs=1e-3), field
    measured = defaults.with_load_sensitivity()
    assert (measured.load_sensitivity_mean, measured.load_sensitivity_sd) == pytest.approx(
        (prior.load_sensitivity_mean, prior.load_sensitivity_sd), abs=1e-3
    )


def test_prior_covers_every_passenger_set():
    """Each measured car/SUV shape lies within 2.5 prior sds (a tyre the prior rules out would
    bias C_x for that tyre)."""
    prior = curve_shape_prior()
    sets = distinct_passenger_sets()
    z_c = (np.log(sets["C"] - 1) - prior.shape_excess_log_mean) / prior.shape_excess_log_sd
    z_e = (np.log(1 - sets["E_traction"]) - prior.curvature_log_mean) / prior.curvature_log_sd
    assert np.all(np.abs(z_c) < 2.5) and np.all(np.abs(z_e) < 2.5)
    q = sets["PKX2"] / sets["PKX1"] + sets["PKX3"]
    z_q = (q - prior.load_sensitivity_mean) / prior.load_sensitivity_sd
    assert np.all(np.abs(z_q) < 2.5)


def test_load_sensitivity_of_the_tno_tyre():
    """Pacejka's 205/60R15: PKX1 21.69, PKX2 13.774, PKX3 −0.4119 give q = 0.223."""
    sets = distinct_passenger_sets()
    tno = sets[sets["tyre"].str.contains("TNO_car205_60R15")].iloc[0]
    assert tno["PKX2"] / tno["PKX1"] + tno["PKX3"] == pytest.approx(0.2231, abs=1e-4)


def test_too_few_sets_is_an_error():
    with pytest.raises(ValueError, match="at least 3 car/SUV sets, got 2"):
        curve_shape_prior(distinct_passenger_sets().iloc[:2])
