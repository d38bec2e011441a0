"""Vehicle loading, wheel loads and the single-track model in both directions."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes._resources import models_dir
from tyrebayes.physics.vehicle import (
    GRAVITY_MPS2,
    SingleTrackState,
    Vehicle,
    aero_drag,
    single_track_accelerations,
    single_track_derivatives,
    single_track_inverse,
    static_wheel_loads,
    wheel_loads,
)


@pytest.fixture(params=["compact_fwd", "suv_rav4"])
def vehicle(request):
    return load_vehicle(request.param)


def test_compact_car_matches_thesis_table_6_1_front_wheel_load():
    # Thesis Table 6.1: F_z = 4865 N on a front wheel.
    assert float(static_wheel_loads(load_vehicle("compact_fwd"))[0]) == pytest.approx(4865, abs=1)


def test_wheel_loads_sum_to_weight_and_move_the_right_way(vehicle):
    weight = vehicle.mass_kg * GRAVITY_MPS2
    loads = wheel_loads(vehicle, jnp.array([0.0, 3.0, -5.0, 0.0]), jnp.array([0.0, 0.0, 0.0, 4.0]))
    np.testing.assert_allclose(loads.sum(-1), weight, rtol=1e-12)
    static, accel, brake, left_turn = loads
    assert accel[0] < static[0] and accel[2] > static[2]  # acceleration unloads the front
    assert brake[0] > static[0] and brake[2] < static[2]  # braking loads the front
    assert left_turn[1] > left_turn[0] and left_turn[3] > left_turn[2]  # left turn loads the right


@pytest.mark.parametrize("drive", ["fwd", "rwd", "awd"])
def test_inverse_single_track_recovers_forward_forces(drive):
    base = load_vehicle("compact_fwd")
    v = Vehicle(**{**{k: getattr(base, k) for k in Vehicle.__dataclass_fields__}, "drive": drive})
    key = jax.random.PRNGKey(0)
    n = 50
    steer = 0.1 * jax.random.normal(key, (n,))
    fy_front = 4000.0 * jax.random.normal(jax.random.PRNGKey(1), (n,))
    fy_rear = 3000.0 * jax.random.normal(jax.random.PRNGKey(2), (n,))
    traction = 2000.0 * jax.random.normal(jax.random.PRNGKey(3), (n,))
    share = v.traction_front_share
    fx_front, fx_rear = share * traction, (1 - share) * traction
    ax, ay, yaw_acc = single_track_accelerations(v, steer, fx_front, fy_front, fx_rear, fy_rear)
    recovered = single_track_inverse(v, ax, ay, yaw_acc, steer)
    for got, want in zip(recovered, (fx_front, fy_front, fx_rear, fy_rear), strict=True):
        np.testing.assert_allclose(got, want, atol=1e-8)


def test_inverse_accounts_for_resistance(vehicle):
    drag = aero_drag(vehicle, 27.8)
    fx1, _, fx2, _ = single_track_inverse(vehicle, 0.0, 0.0, 0.0, 0.0, resistance_n=drag)
    assert float(fx1 + fx2) == pytest.approx(float(drag))


def test_forward_dynamics_steady_turn_has_centripetal_balance(vehicle):
    state = SingleTrackState(vx_mps=20.0, vy_mps=0.0, yaw_rate_radps=0.2)
    ay = 20.0 * 0.2
    lf, lr = vehicle.cog_to_front_axle_m, vehicle.cog_to_rear_axle_m
    fy_front = vehicle.mass_kg * ay * lr / vehicle.wheelbase_m
    fy_rear = vehicle.mass_kg * ay * lf / vehicle.wheelbase_m
    d = single_track_derivatives(vehicle, state, 0.0, 0.0, fy_front, 0.0, fy_rear)
    assert float(d.vy_mps) == pytest.approx(0.0, abs=1e-9)
    assert float(d.yaw_rate_radps) == pytest.approx(0.0, abs=1e-9)


def test_single_track_gradients_match_finite_differences():
    v = load_vehicle("compact_fwd")
    f = lambda x: single_track_inverse(v, x[0], x[1], x[2], x[3])[0]
    x = jnp.array([1.2, 2.0, 0.3, 0.05])
    h = 1e-6
    numeric = jnp.array([(f(x + h * e) - f(x - h * e)) / (2 * h) for e in jnp.eye(4)])
    np.testing.assert_allclose(jax.grad(f)(x), numeric, rtol=1e-6, atol=1e-6)


def test_vmap_over_accelerations():
    v = load_vehicle("suv_rav4")
    out = jax.vmap(lambda a: single_track_inverse(v, a, 0.0, 0.0, 0.0)[0])(jnp.linspace(-3, 3, 7))
    np.testing.assert_allclose(out, v.mass_kg * jnp.linspace(-3, 3, 7))


@pytest.mark.parametrize(
    ("field", "value"),
    [("mass_kg", 0.0), ("mass_kg", -5.0), ("wheelbase_m", -1.0), ("drive", "fourwheel")],
)
def test_bad_vehicle_values_name_the_field(field, value):
    base = load_vehicle("compact_fwd")
    fields = {k: getattr(base, k) for k in Vehicle.__dataclass_fields__}
    fields[field] = value
    with pytest.raises(ValueError, match=field):
        Vehicle(**fields)


# --- audit of issue 2: parameter batches, traced drive share, messages name field and value ---


def _fields(v: Vehicle) -> dict:
    return {k: getattr(v, k) for k in Vehicle.__dataclass_fields__}


def test_vmap_over_a_batch_of_vehicle_parameter_sets():
    base = load_vehicle("compact_fwd")
    masses = jnp.array([1200.0, 1600.0, 2100.0])
    batch = Vehicle(
        **(
            _fields(base)
            | dict(
                mass_kg=masses,
                cog_height_m=jnp.array([0.45, 0.55, 0.70]),
                front_drive_fraction=jnp.array([0.3, 0.5, 0.9]),
                drive="awd",
            )
        )
    )
    loads = eqx_filter_vmap(lambda v: wheel_loads(v, 2.0, -3.0))(batch)
    np.testing.assert_allclose(loads.sum(-1), masses * GRAVITY_MPS2, rtol=1e-12)
    steer, fy1, fy2, traction = 0.05, 1500.0, 1200.0, 2500.0

    def round_trip(v):
        share = v.traction_front_share
        forces = (share * traction, fy1, (1 - share) * traction, fy2)
        ax, ay, yaw_acc = single_track_accelerations(v, steer, *forces)
        return jnp.stack(single_track_inverse(v, ax, ay, yaw_acc, steer)), jnp.stack(forces)

    got, want = eqx_filter_vmap(round_trip)(batch)
    np.testing.assert_allclose(got, want, atol=1e-8)


def eqx_filter_vmap(fn):
    import equinox as eqx

    return eqx.filter_vmap(fn)


def test_inverse_is_differentiable_in_the_drive_share_under_jit():
    import equinox as eqx

    base = load_vehicle("compact_fwd")

    @eqx.filter_jit
    def front_force(share):
        v = Vehicle(**(_fields(base) | dict(drive="awd", front_drive_fraction=share)))
        return single_track_inverse(v, 1.0, 2.0, 0.1, 0.05)[0]

    h = 1e-6
    numeric = (front_force(0.4 + h) - front_force(0.4 - h)) / (2 * h)
    assert float(jax.grad(front_force)(jnp.asarray(0.4))) == pytest.approx(float(numeric), rel=1e-6)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("mass_kg", 0.0),
        ("mass_kg", -5.0),
        ("wheelbase_m", -1.0),
        ("yaw_inertia_kgm2", 0.0),
        ("wheel_radius_m", -0.3),
        ("steering_ratio", 0.0),
        ("drive", "fourwheel"),
    ],
)
def test_bad_vehicle_message_names_field_and_value(field, value):
    fields = _fields(load_vehicle("compact_fwd")) | {field: value}
    with pytest.raises(ValueError, match=rf"Vehicle\.{field}: .*got '?{value}'?"):
        Vehicle(**fields)


@pytest.mark.parametrize("key", ["mass_kg", "drive", "wheel_radius_m", "steering_ratio"])
def test_toml_missing_each_required_key_is_named(tmp_path, key):
    text = (models_dir() / "vehicles" / "suv_rav4.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text("\n".join(ln for ln in text.splitlines() if not ln.startswith(f"{key} ")))
    with pytest.raises(ValueError, match=f"missing key '{key}'"):
        load_vehicle(bad)


def test_toml_unknown_drive_names_field_and_value(tmp_path):
    text = (models_dir() / "vehicles" / "compact_fwd.toml").read_text()
    bad = tmp_path / "drive.toml"
    bad.write_text(text.replace('drive = "fwd"', 'drive = "4wd"'))
    assert bad.read_text() != text
    with pytest.raises(ValueError, match="drive.*'4wd'"):
        load_vehicle(bad)


@pytest.mark.parametrize(
    ("line", "replacement", "key"),
    [
        ("mass_kg = 1600.0", "mass_kg = 1.7e6", "mass_kg"),
        ("mass_kg = 1600.0", "mass_kg = 1.6", "mass_kg"),  # tonnes
        ("wheel_radius_m = 0.31", "wheel_radius_m = 310.0", "wheel_radius_m"),  # mm
        ("steering_ratio = 15.5", "steering_ratio = 1.0", "steering_ratio"),
    ],
)
def test_toml_outside_a_road_car_is_named(tmp_path, line, replacement, key):
    text = (models_dir() / "vehicles" / "compact_fwd.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(line, replacement))
    assert bad.read_text() != text
    with pytest.raises(ValueError, match=rf"{key}: expected a road car's value in .*, got"):
        load_vehicle(bad)
