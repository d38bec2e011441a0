"""Tests for the ISO 3888-2 lane-change simulation and critical speed."""

import jax
import jax.numpy as jnp
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.physics.lanechange import (
    Tyres,
    critical_speed,
    critical_speed_sensitivity,
    iso3888_2_course,
    run_margin,
)

VEH = load_vehicle("compact_fwd")
COURSE = iso3888_2_course(VEH.width_m)


def test_course_geometry_matches_iso_3888_2() -> None:
    w = 1.8
    std = iso3888_2_course(w, exit_lane="standard")
    assert std.x_edges_m == pytest.approx((0.0, 12.0, 25.5, 36.5, 49.0, 61.0))
    assert std.lane1_width_m == pytest.approx(1.1 * w + 0.25)
    assert std.lane3_width_m == pytest.approx(w + 1.0)
    assert std.lane5_width_m == pytest.approx(1.3 * w + 0.25)
    assert iso3888_2_course(w).lane5_width_m == pytest.approx(3.0)  # thesis exit lane
    (_, _, _, l1), (_, _, r3, _), _ = std.lane_bounds
    assert r3 - l1 == pytest.approx(1.0)  # lateral offset between lanes 1 and 3
    with pytest.raises(ValueError, match="exit_lane"):
        iso3888_2_course(w, exit_lane="x")


def test_low_speed_passes_absurd_speed_fails() -> None:
    f = jax.jit(lambda v: run_margin(VEH, Tyres(18.0, 1.0), v, COURSE))
    assert float(f(8.0)) > 0.0
    assert float(f(45.0)) < 0.0  # 162 km/h


def test_vmax_rises_with_mu_and_tolerance_honoured() -> None:
    tol = 0.1
    cs = jax.jit(jax.vmap(lambda mu: critical_speed(VEH, Tyres(18.0, mu), COURSE, tol_mps=tol)))(
        jnp.array([0.6, 1.0])
    )
    assert bool(jnp.all(cs.bracketed))
    assert bool(jnp.all(cs.v_fail_mps - cs.v_max_mps <= tol + 1e-12))
    assert float(cs.v_max_mps[1]) > float(cs.v_max_mps[0]) + 1.0  # > 3.6 km/h more with 0.4 more mu
    # the bracket is genuine: lower end passes, upper end fails
    assert float(run_margin(VEH, Tyres(18.0, 1.0), cs.v_max_mps[1], COURSE)) > 0.0
    assert float(run_margin(VEH, Tyres(18.0, 1.0), cs.v_fail_mps[1], COURSE)) <= 0.0


def test_sensitivity_sign() -> None:
    s = critical_speed_sensitivity(VEH, Tyres(18.0, 0.8), COURSE, tol_mps=0.05)
    assert bool(jnp.isfinite(s["dv_dmu_y"]))
    assert float(s["dv_dmu_y"]) > 0.0


def test_axle_tyres_convert_per_axle_stiffness_and_reduce_to_one_stiffness() -> None:
    from tyrebayes.physics.lanechange import AxleTyres, static_axle_loads
    from tyrebayes.physics.vehicle import GRAVITY_MPS2

    # c_y over the static axle load: C_f = c_y_front · m g l_r / L, C_r = c_y_rear · m g l_f / L
    tyres = AxleTyres(14.0, 17.0, 1.0)
    c_f, c_r = tyres.cornering_stiffness_n_per_rad(VEH)
    m, wb = VEH.mass_kg, VEH.wheelbase_m
    assert float(c_f) == pytest.approx(14.0 * m * GRAVITY_MPS2 * VEH.cog_to_rear_axle_m / wb)
    assert float(c_r) == pytest.approx(17.0 * m * GRAVITY_MPS2 * VEH.cog_to_front_axle_m / wb)
    assert sum(static_axle_loads(VEH)) == pytest.approx(m * GRAVITY_MPS2)
    back = AxleTyres.from_cornering_stiffness(VEH, c_f, c_r, 1.0)
    assert float(back.c_y_front) == pytest.approx(14.0)
    assert float(back.c_y_rear) == pytest.approx(17.0)
    # equal axles are the one-stiffness model
    f = jax.jit(lambda t, v: run_margin(VEH, t, v, COURSE))
    assert float(f(AxleTyres(16.0, 16.0, 0.9), 18.0)) == float(f(Tyres(16.0, 0.9), 18.0))


def test_a_tyre_too_slippery_for_the_search_range_lies_below_it() -> None:
    # On ice even the range's lowest speed fails: no bracket, and the result says which end.
    cs = critical_speed(VEH, Tyres(18.0, 0.1), COURSE, tol_mps=1.0)
    assert (bool(cs.bracketed), bool(cs.below_range), bool(cs.above_range)) == (False, True, False)
    ok = critical_speed(VEH, Tyres(18.0, 1.0), COURSE, tol_mps=1.0)
    assert (bool(ok.bracketed), bool(ok.below_range), bool(ok.above_range)) == (True, False, False)
