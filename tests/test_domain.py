"""Domain constants and loaders defined once (tyrebayes._domain)."""

import numpy as np
import pytest

from tyrebayes._domain import (
    GRAVITY,
    SURFACES,
    TYRE_TYPES,
    load_braking_data,
    load_lane_change_speeds,
    load_vehicle,
    mean_deceleration_g,
    vehicle_names,
)
from tyrebayes._resources import models_dir
from tyrebayes.physics.vehicle import GRAVITY_MPS2, Vehicle


def test_one_gravity_one_order():
    assert GRAVITY == GRAVITY_MPS2 == 9.80665
    assert TYRE_TYPES == ("winter", "all_season", "summer")
    assert SURFACES == ("snow", "ice", "wet", "dry")


def test_vehicle_names_resolve_and_a_vehicle_passes_through():
    names = vehicle_names()
    assert {"compact_fwd", "suv_rav4"} <= set(names)
    v = load_vehicle("suv_rav4")
    assert isinstance(v, Vehicle) and load_vehicle(v) is v
    assert load_vehicle(models_dir() / "vehicles" / "suv_rav4.toml") == v


def test_measured_tables_load_with_their_columns():
    braking = load_braking_data()
    assert {"source", "tyre_type", "surface", "speed_from_kmh", "distance_m"} <= set(braking)
    assert set(braking["tyre_type"]) <= set(TYRE_TYPES)
    assert set(braking["surface"]) <= set(SURFACES)
    table = load_lane_change_speeds()
    assert len(table) == 6 and set(table["tyre_type"]) <= set(TYRE_TYPES)


def test_mean_deceleration_is_v_squared_over_two_g_d():
    # 100 km/h to rest in 39.3 m is 1.0 g.
    v = 100 / 3.6
    assert mean_deceleration_g(100.0, v**2 / (2 * GRAVITY)) == pytest.approx(1.0)
    np.testing.assert_allclose(
        mean_deceleration_g([50.0, 100.0], [10.0, 40.0])[1] * 40, (v**2 / (2 * GRAVITY))
    )


def test_toml_missing_key_is_named(tmp_path):
    text = (models_dir() / "vehicles" / "compact_fwd.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text("\n".join(line for line in text.splitlines() if not line.startswith("mass_kg")))
    with pytest.raises(ValueError, match="mass_kg"):
        load_vehicle(bad)


def test_toml_bad_value_and_unknown_preset(tmp_path):
    text = (models_dir() / "vehicles" / "compact_fwd.toml").read_text()
    bad = tmp_path / "neg.toml"
    bad.write_text(text.replace("mass_kg = 1600.0", "mass_kg = -3.0"))
    with pytest.raises(ValueError, match="mass_kg.*-3.0"):
        load_vehicle(bad)
    with pytest.raises(ValueError, match="no_such_car"):
        load_vehicle("no_such_car")
