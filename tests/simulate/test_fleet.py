"""Tests of the synthetic fleet simulator (tyrebayes.simulate.fleet)."""

import jax
import numpy as np
import pytest

from tyrebayes.simulate.fleet import (
    AGE_REF_YEARS,
    THESIS_AGED_TYRE_EFFECT,
    TYPE_FRICTION,
    inverse_stiffness,
    simulate_fleet,
)


def test_contract_columns_and_types():
    table, truth = simulate_fleet(0, 26, n_decoys=3)
    for col in ("tyre_id", "tyre_type", "c_xr", "c_xr_sd", "mu", "surface"):
        assert col in table.columns
    for col in ("age_years", "tread_depth_mm", "pressure_bar", "load_index"):
        assert np.issubdtype(table[col].dtype, np.number)
    assert truth["decoys"] == ["decoy_1", "decoy_2", "decoy_3"]
    assert set(table["tyre_type"]) == {"winter", "all_season", "summer"}
    assert len(table) == 26 and table["tyre_id"].is_unique
    assert (table["c_xr"] > 0).all() and (table["c_xr_sd"] > 0).all()
    # At least two sets per type so every type can be fitted.
    assert table["tyre_type"].value_counts().min() >= 2


def test_fixed_seed_reproducible_and_jax_key_accepted():
    a, _ = simulate_fleet(5, 30)
    b, _ = simulate_fleet(5, 30)
    assert a.equals(b)
    c, _ = simulate_fleet(jax.random.key(5), 30)
    d, _ = simulate_fleet(jax.random.PRNGKey(5), 30)
    assert len(c) == 30 and c.equals(d)


def test_type_stiffness_and_snow_friction_ranges_match_thesis_and_braking_data():
    table, _ = simulate_fleet(1, 3000)
    med = table.groupby("tyre_type")["c_xr"].median()
    # Thesis Fig 6.1: winter ~25-35, summer ~45-65.
    assert 27 < med["winter"] < 33 and 50 < med["summer"] < 60
    mu = table.groupby("tyre_type")["mu"].mean()
    # Braking data: winter snow mean deceleration 0.34-0.45 g, summer < 0.18 g (peak a bit above).
    assert 0.40 < mu["winter"] < 0.50
    assert 0.12 < mu["summer"] < 0.22
    assert mu["summer"] < mu["all_season"] < mu["winter"]


def test_snow_mu_decreases_with_stiffness_within_winter():
    table, _ = simulate_fleet(2, 2000, type_shares={"winter": 1.0})
    slope = np.polyfit(inverse_stiffness(table["c_xr"].to_numpy()), table["mu"], 1)[0]
    # True slope 0.10 per unit of 100/C_xr, attenuated by the c_xr noise; must be clearly > 0.
    assert 0.06 < slope < 0.11


def test_multiple_surfaces_long_format():
    table, truth = simulate_fleet(3, 20, surface=("snow", "dry"))
    assert len(table) == 40
    assert set(truth["type_params"]) == {"snow", "dry"}
    wide = table.pivot(index="tyre_id", columns="surface", values="mu")
    assert (wide["dry"] > wide["snow"]).all()
    assert truth["type_params"]["snow"]["winter"]["b"] == TYPE_FRICTION["snow"]["winter"][1]


def test_age_effect_lowers_snow_mu_and_stiffens_at_thesis_size():
    kwargs = {"type_shares": {"winter": 1.0}, "n_decoys": 0}
    base, tb = simulate_fleet(4, 4000, **kwargs)
    aged, ta = simulate_fleet(4, 4000, effects=("age",), **kwargs)
    assert ta["effects"] == {"age": THESIS_AGED_TYRE_EFFECT}
    old = aged["age_years"] > 6.5
    # Same seed -> same covariates; the effect changes only mu and stiffness.
    assert np.allclose(base["age_years"], aged["age_years"])
    assert (ta["c_xr_true"][old] > tb["c_xr_true"][old] * 1.15).all()
    # Thesis Sec 6.1: over-aged winter sets are "as bad as summer tyres" (~0.18-0.25 on snow).
    assert 0.15 < aged.loc[old, "mu"].mean() < 0.28
    # Tyres at the reference age are unaffected on average (tolerance ~3 standard errors).
    near = (aged["age_years"] - AGE_REF_YEARS).abs() < 0.3
    assert abs(aged.loc[near, "mu"].mean() - base.loc[near, "mu"].mean()) < 0.02


@pytest.mark.parametrize("effect,column", [("load", "load_index"), ("pressure", "pressure_bar")])
def test_other_effects_act_through_their_column(effect, column):
    base, _ = simulate_fleet(6, 3000, n_decoys=0)
    eff, truth = simulate_fleet(6, 3000, effects=(effect,), effect_size=0.1, n_decoys=0)
    assert truth["effects"] == {effect: 0.1}
    diff = (eff["mu"] - base["mu"]).to_numpy()
    r = np.corrcoef(diff, eff[column])[0, 1]
    assert r < -0.8


def test_decoys_do_nothing():
    t1, _ = simulate_fleet(7, 50, n_decoys=0)
    t2, _ = simulate_fleet(7, 50, n_decoys=4)
    # Decoys come from their own random stream: every other column is unchanged.
    assert t1.equals(t2[t1.columns])
    assert [c for c in t2.columns if c.startswith("decoy")] == [f"decoy_{i}" for i in (1, 2, 3, 4)]


def test_bad_arguments():
    with pytest.raises(ValueError, match="effects"):
        simulate_fleet(0, 10, effects=("colour",))
    with pytest.raises(ValueError, match="noise"):
        simulate_fleet(0, 10, noise="cauchy")
    with pytest.raises(ValueError, match="surface"):
        simulate_fleet(0, 10, surface="gravel")
    with pytest.raises(ValueError, match="n_sets"):
        simulate_fleet(0, 0)


def test_tread_effect_and_heavy_tailed_noise_change_only_mu():
    """The tread effect adds effect_size per mm around 6 mm; Student-t(3) noise keeps the sd."""
    base, _ = simulate_fleet(3, 400)
    tread, truth = simulate_fleet(3, 400, effects=("tread",), effect_size=0.05)
    assert truth["effect_columns"]["tread"] == "tread_depth_mm"
    shift = tread["mu"] - base["mu"]
    expected = 0.05 * (base["tread_depth_mm"] - 6.0)
    inside = (base["mu"] > 0.03) & (tread["mu"] > 0.03)  # away from the clip at 0.02
    assert np.allclose(shift[inside], expected[inside], atol=0.0051 * 0.05 + 1e-9)
    assert (tread["c_xr"] == base["c_xr"]).all()
    heavy, _ = simulate_fleet(3, 400, noise="student_t3")
    assert (heavy["c_xr"] == base["c_xr"]).all() and not (heavy["mu"] == base["mu"]).all()
