"""Drive history to γ: layout of tyre sets, bad histories, and recovery on a synthetic history."""

import jax
import numpy as np
import pandas as pd
import pytest

from tyrebayes import BadInputError
from tyrebayes.inference.wear.history import drive_history, reading_exposure, tread_readings
from tyrebayes.inference.wear.history_fit import fit_wear_history
from tyrebayes.inference.wear.history_predict import wear_history_predictions
from tyrebayes.physics.wear import TreadGeometry

GAMMA = 0.04


def synthetic_table(seed=0, n=30, rotation=14, replacement=None):
    """Evidence rows whose radius ratio drifts with a known γ (work known exactly)."""
    rng = np.random.default_rng(seed)
    geom = TreadGeometry()
    dist = np.full(n, 10.0)
    interval = rng.uniform(250.0, 500.0, n)
    odo = np.concatenate([[0.0], np.cumsum(interval[:-1])])
    wf, wr = rng.uniform(1e4, 2.5e4, n), rng.uniform(200.0, 1000.0, n)
    loss = GAMMA * np.column_stack([wf, wr]) * (interval / dist)[:, None] / 2 / geom.wear_area_mm2
    pair_loss = np.zeros(4)
    on = np.array([0, 1])
    y = []
    for k in range(n):
        if k == rotation:
            on = on[::-1].copy()
        if k == replacement:
            on = np.array([2, 3])
        y.append(0.3 - (pair_loss[on[0]] - pair_loss[on[1]]) + 0.01 * rng.standard_normal())
        pair_loss[on] += loss[k]
    return pd.DataFrame(
        {
            "distance_km": dist,
            "odometer_start_km": odo,
            "work_x_front_j": wf,
            "work_x_front_sd_j": 0.02 * wf,
            "work_x_rear_j": wr,
            "work_x_rear_sd_j": 0.05 * wr,
            "radius_ratio_front_rear": 1 + np.array(y) / geom.outer_radius_mm,
            "radius_ratio_front_rear_sd": np.full(n, 3e-5),
            "speed_scale": np.nan,
            "tyre_temperature_c": 20.0,
        }
    ), pair_loss


def test_history_finds_the_rotation_and_lays_out_the_pairs():
    table, _ = synthetic_table()
    h = drive_history(table)
    assert h.changes.index.tolist() == [14]
    assert h.changes.kind == ("rotation",)
    assert h.pair[13].tolist() == [0, 1] and h.pair[14].tolist() == [1, 0]
    assert h.n_pairs == 2
    assert h.scale == pytest.approx(h.interval_km / 10.0)


def test_one_drive_is_bad_input():
    table, _ = synthetic_table()
    with pytest.raises(BadInputError, match="at least 2 drives"):
        drive_history(table.iloc[:1])


def test_odometer_running_backwards_is_bad_input():
    table, _ = synthetic_table()
    table.loc[5, "odometer_start_km"] = 0.0
    with pytest.raises(BadInputError, match="odometer"):
        drive_history(table)


def test_increasing_readings_are_bad_input():
    table, _ = synthetic_table()
    h = drive_history(table)
    readings = tread_readings(
        pd.DataFrame(
            {"odometer_km": [1000.0, 3000.0], "axle": ["front", "front"], "depth_mm": [7.5, 8.4]}
        )
    )
    with pytest.raises(BadInputError, match="do not increase"):
        reading_exposure(h, readings)


def test_reading_exposure_follows_the_pair_across_a_rotation():
    table, _ = synthetic_table()
    h = drive_history(table)
    end = float(h.odometer_km[-1] + h.interval_km[-1])
    readings = tread_readings(
        pd.DataFrame({"odometer_km": [end], "axle": ["rear"], "depth_mm": [7.0]})
    )
    exposure, pair = reading_exposure(h, readings)
    # the rear pair at the end is pair 0: it was on the front before drive 14
    assert pair.tolist() == [0]
    assert exposure[0, :14, 0].sum() == pytest.approx(14.0)
    assert exposure[0, 14:, 1].sum() == pytest.approx(len(table) - 14)
    assert exposure[0, :14, 1].sum() == 0.0


def test_log_density_peaks_at_the_true_gamma():
    """Fast form of the recovery check: the model's density over γ·s peaks at the true γ."""
    from numpyro.infer.util import log_density

    from tyrebayes.inference.wear.data import WearPriors
    from tyrebayes.inference.wear.history_fit import wear_history_model

    table, _ = synthetic_table(seed=1)
    h = drive_history(table)
    args = (h, None, None, None, False, WearPriors(), float(TreadGeometry().wear_area_mm2))
    grid = GAMMA * np.exp(np.linspace(-0.3, 0.3, 13))

    @jax.jit
    def density(log_g):
        params = {"log_gamma_work": log_g, "sigma_ratio_mm": 0.01, "tau": 0.05}
        return log_density(wear_history_model, args, {}, params)[0]

    dens = [float(density(np.log(g))) for g in grid]
    best = grid[int(np.argmax(dens))]
    assert abs(best / GAMMA - 1) < 0.06


@pytest.mark.slow
def test_gamma_is_recovered_from_radius_drift():
    """Exact work: the work-scale factor is 1, so γ·s must cover the true γ."""
    table, pair_loss = synthetic_table(seed=1)
    h = drive_history(table)
    fit = fit_wear_history(h, num_warmup=150, num_samples=150, extended=False, seed=1)
    assert fit.kind == "wear_history"
    gw = fit.draws("gamma_work")
    lo, hi = np.quantile(gw, (0.05, 0.95))
    assert lo < GAMMA < hi
    assert hi - lo < 0.3 * GAMMA  # the drift pins γ·s tightly
    # γ itself keeps the work-scale prior's width
    g = fit.draws("gamma")
    assert np.quantile(g, 0.95) - np.quantile(g, 0.05) > hi - lo
    out, ratio = wear_history_predictions(fit, h)
    assert out["tyre_changes"][0]["kind"] == "rotation"
    assert out["km_to_1_6mm"]["mean"] > out["km_to_3mm"]["mean"]
    assert ratio.shape == gw.shape
