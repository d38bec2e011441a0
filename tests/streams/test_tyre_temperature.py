"""The driven tyres' temperature estimated from a stream (lumped heat balance)."""

import numpy as np
import pytest

from tyrebayes._errors import BadInputError
from tyrebayes.physics.thermal import ThermalParams, steady_state_temperature
from tyrebayes.streams.tyre_temperature import driven_tyre_temperature, features_tyre_temperature


def constant_drive(hours: float = 2.0, rate_hz: float = 10.0):
    t = np.arange(0.0, hours * 3600.0, 1.0 / rate_hz)
    return t, np.full(t.size, 27.78), np.full(t.size, 4865.0), np.full(t.size, 20.0)


def test_constant_driving_settles_at_the_steady_state():
    t, speed, load, power = constant_drive()
    temp = driven_tyre_temperature(t, speed, load, power, ambient_c=10.0)
    expected = float(steady_state_temperature(ThermalParams(), 4865.0, 27.78, 20.0, 10.0))
    assert temp[0] == 10.0
    # Two hours are 15 time constants at this speed (~8 min): settled to 0.05 K.
    assert temp[-1] == pytest.approx(expected, abs=0.05)
    assert np.all(np.diff(temp) >= -1e-9)  # warming only, from a cold start


def test_dropped_samples_are_bridged_not_propagated():
    t, speed, load, power = constant_drive(hours=0.5)
    clean = driven_tyre_temperature(t, speed, load, power, ambient_c=10.0)
    speed = speed.copy()
    speed[1000:1200] = np.nan  # 20 s dropped: the thermal mass does not notice
    gappy = driven_tyre_temperature(t, speed, load, power, ambient_c=10.0)
    assert np.all(np.isfinite(gappy))
    assert np.max(np.abs(gappy - clean)) < 1e-6


def test_a_warm_start_cools_towards_the_steady_state_when_parked():
    t = np.arange(0.0, 1800.0, 1.0)
    zeros = np.zeros(t.size)
    temp = driven_tyre_temperature(
        t, zeros, np.full(t.size, 4000.0), zeros, ambient_c=5.0, initial_c=40.0
    )
    assert temp[0] == 40.0 and 5.0 < temp[-1] < 40.0


def test_bad_inputs_name_what_was_expected():
    t, speed, load, power = constant_drive(hours=0.01)
    with pytest.raises(BadInputError, match="load expected shape"):
        driven_tyre_temperature(t, speed, load[:-1], power, ambient_c=10.0)
    with pytest.raises(BadInputError, match="finite ambient"):
        driven_tyre_temperature(t, speed, load, power, ambient_c=float("nan"))


def test_simulated_drive_temperature_is_read_from_the_stream():
    """The simulator's tyres heat with other coefficients than the nominal ones the estimate
    uses (ThermalSpread); the estimate must follow the warm-up's shape: the model infers the
    stiffness' temperature sensitivity, so a scale error is absorbed, a wrong shape is not."""
    from tyrebayes._domain import load_vehicle
    from tyrebayes.simulate.drive import simulate_drive
    from tyrebayes.simulate.vehicle_truth import ThermalSpread, draw_true_thermal
    from tyrebayes.streams import compute_features, validate_stream

    vehicle = load_vehicle("compact_fwd")
    thermal = draw_true_thermal(np.random.default_rng(3), ThermalSpread())
    df, truth = simulate_drive(
        5, vehicle, "summer", duration_s=900.0, ambient_c=15.0, thermal=thermal
    )
    features = compute_features(validate_stream(df, vehicle), vehicle)
    estimate = features_tyre_temperature(features, ambient_c=15.0)
    index = np.searchsorted(truth.time_s, features.time_s - 1e-9)
    true = np.asarray(truth.tyre_temperature_c)[index][:, :2].mean(axis=1)
    assert np.corrcoef(estimate, true)[0, 1] > 0.98
    rise_ratio = (estimate[-1] - 15.0) / (true[-1] - 15.0)
    assert 0.5 < rise_ratio < 2.0


def test_padding_the_scan_leaves_the_temperatures_as_they_are():
    """The block scan runs padded to whole multiples of _PAD_BLOCKS; unpadded it gives the same."""
    import jax.numpy as jnp

    from tyrebayes.physics.thermal import simulate_tyre_temperature
    from tyrebayes.streams import tyre_temperature as tt

    rng = np.random.default_rng(3)
    t = np.arange(0.0, 1500.0, 0.1)  # 1,500 blocks: padded to 2,048
    speed = 20.0 + rng.normal(0.0, 2.0, t.size)
    load, power = np.full(t.size, 4500.0), np.abs(rng.normal(0.0, 300.0, t.size))
    padded = driven_tyre_temperature(t, speed, load, power, ambient_c=12.0)

    block = 10
    means = [x.reshape(-1, block).mean(axis=1) for x in (speed, load, power)]
    means[0] = np.abs(means[0])
    t_blocks = t[0] + (np.arange(t.size // block) + 0.5) * block * 0.1
    direct = np.asarray(
        simulate_tyre_temperature(
            ThermalParams(), jnp.asarray(t_blocks), *map(jnp.asarray, means), 12.0, 12.0
        )
    )
    expected = np.interp(t, np.r_[t[0], t_blocks], np.r_[12.0, direct])
    assert tt._PAD_BLOCKS < t_blocks.size < 2 * tt._PAD_BLOCKS
    np.testing.assert_allclose(padded, expected, rtol=1e-12, atol=1e-12)


def test_each_drives_ambient_does_not_compile_a_scan_of_its_own():
    # A fleet worker sees thousands of drives, each at its own ambient: a scan compiled per
    # value would cost a compile (or cache load) per drive and stay in memory.
    from tyrebayes.streams import tyre_temperature as module

    t = np.arange(0.0, 600.0, 0.1)
    inputs = (np.full(t.size, 20.0), np.full(t.size, 4000.0), np.zeros(t.size))
    module.driven_tyre_temperature(t, *inputs, ambient_c=5.0)
    before = module._scan._cached._cache_size()
    for ambient, start in ((12.5, None), (-3.0, 30.0), (21.0, 21.5)):
        temp = module.driven_tyre_temperature(t, *inputs, ambient_c=ambient, initial_c=start)
        assert temp[0] == (ambient if start is None else start)
    assert module._scan._cached._cache_size() == before
