"""Drive history to γ: layout of tyre sets, bad histories, and recovery on a synthetic history."""

import json

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
    assert h.changes.change_type == ("rotation",)
    assert h.pair[13].tolist() == [0, 1] and h.pair[14].tolist() == [1, 0]
    assert h.n_pairs == 2
    assert h.scale == pytest.approx(h.interval_km / 10.0)


def test_history_takes_each_axles_temperature_and_the_cars_rolling_radius():
    table, _ = synthetic_table()
    h = drive_history(table)  # the driven tyres' temperature for both, the outer radius
    assert h.tyre_temperature_c.shape == (table.shape[0], 2)
    assert h.radius_mm == TreadGeometry().outer_radius_mm
    per_axle = table.assign(
        tyre_temperature_front_c=25.0, tyre_temperature_rear_c=21.0, rolling_radius_mm=310.0
    )
    h2 = drive_history(per_axle)
    assert h2.tyre_temperature_c[0].tolist() == [25.0, 21.0]
    assert h2.radius_mm == 310.0
    # the same ratios read as slightly less tread with the smaller radius
    assert h2.ratio_mm == pytest.approx(h.ratio_mm * 310.0 / h.radius_mm)


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


def test_a_later_reading_closes_the_last_drives_interval():
    """The last drive stands for the distance to a tread reading after it, as to a next drive:
    its interval and works grow by that factor; the rest, and an earlier odometer, keep theirs."""
    table, _ = synthetic_table()
    h = drive_history(table)
    assert h.interval_km[-1] == pytest.approx(10.0)  # no next drive: its own distance
    later = h.through(h.odometer_km[-1] + 400.0)
    assert later.interval_km[-1] == pytest.approx(400.0)
    assert later.end_km == pytest.approx(h.odometer_km[-1] + 400.0)
    for name in ("work_j", "work_sd_j", "work_y_j"):
        np.testing.assert_allclose(getattr(later, name)[-1], 40.0 * getattr(h, name)[-1])
        np.testing.assert_array_equal(getattr(later, name)[:-1], getattr(h, name)[:-1])
    assert later.scale[-1] == pytest.approx(40.0 * h.scale[-1])
    assert h.through(h.end_km - 5.0) is h and h.through(float("nan")) is h


def test_the_fit_and_its_predictions_run_to_the_latest_reading():
    table, _ = synthetic_table()
    h = drive_history(table)
    end = h.odometer_km[-1] + 400.0
    readings = tread_readings(
        pd.DataFrame({"odometer_km": [end, end], "axle": ["front", "rear"], "depth_mm": [7.0, 7.6]})
    )
    fit = fit_wear_history(h, readings, num_warmup=20, num_samples=20, num_chains=1)
    assert fit.data.attrs["history_end_km"] == pytest.approx(end)
    pred = wear_history_predictions(fit, h, readings)
    assert pred.history_km == pytest.approx(h.total_km + 390.0)


def test_a_run_short_only_of_effective_draws_runs_again_with_twice_the_draws(monkeypatch):
    """Chains that agree but mix slowly get one more run; any other failure stands."""
    import dataclasses

    from tyrebayes.inference.wear import history_fit

    draws_asked, real_run, real_diagnose = [], history_fit.run_nuts, history_fit.diagnose

    def counted(*args, **kwargs):
        draws_asked.append(kwargs["num_samples"])
        return real_run(*args, **kwargs)

    def failing(reason):
        def diagnose(*args, **kwargs):
            d = real_diagnose(*args, **kwargs)
            first = len(draws_asked) == 1
            return dataclasses.replace(d, converged=False, reasons=(reason,)) if first else d

        return diagnose

    monkeypatch.setattr(history_fit, "run_nuts", counted)
    h = drive_history(synthetic_table()[0])
    monkeypatch.setattr(history_fit, "diagnose", failing("tail ESS 150 < 200"))
    fit = fit_wear_history(h, num_warmup=20, num_samples=20, num_chains=1, extended=False)
    assert draws_asked == [20, 40]
    settings = json.loads(fit.provenance.settings)
    assert settings["num_samples"] == 40 and fit.data.posterior.sizes["draw"] == 40
    draws_asked.clear()
    monkeypatch.setattr(history_fit, "diagnose", failing("R-hat 1.100 > 1.02"))
    fit = fit_wear_history(h, num_warmup=20, num_samples=20, num_chains=1, extended=False)
    assert draws_asked == [20] and fit.diagnostics.reasons == ("R-hat 1.100 > 1.02",)


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
        params = {
            "log_gamma_work": log_g,
            "lateral_z": np.zeros(2),
            "sigma_ratio_mm": 0.01,
            "tau": 0.05,
        }
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
    pred = wear_history_predictions(fit, h)
    out, ratio = pred.to_dict(), pred.wear_over_reference
    assert out["tyre_changes"][0]["change_type"] == "rotation"
    assert out["km_to_1_6mm"]["mean"] > out["km_to_3mm"]["mean"]
    assert ratio.shape == gw.shape


def cornering_history(seed=3, n=14, lateral_scale=0.8):
    """A history whose tyres wear by cornering too: the rear axle almost only laterally.

    The evidence's lateral work reads the truth / ``lateral_scale`` (a type-prior c_y that is
    too soft by that factor); readings of both axles every few drives.
    """
    rng = np.random.default_rng(seed)
    geom = TreadGeometry()
    dist = np.full(n, 10.0)
    interval = rng.uniform(800.0, 1200.0, n)
    odo = np.concatenate([[0.0], np.cumsum(interval[:-1])])
    wx = np.column_stack([rng.uniform(1e4, 2e4, n), rng.uniform(100.0, 300.0, n)])
    wy_true = np.column_stack([rng.uniform(1e4, 2e4, n), rng.uniform(0.6e4, 1.2e4, n)])
    wy_ev = wy_true / lateral_scale
    per_tyre = GAMMA * (wx + wy_true) * (interval / dist)[:, None] / 2 / geom.wear_area_mm2
    lost = np.cumsum(per_tyre, axis=0)
    y = 0.3 - np.concatenate([[0.0], (lost[:-1, 0] - lost[:-1, 1])])
    y = y + 0.005 * rng.standard_normal(n)
    table = pd.DataFrame(
        {
            "distance_km": dist,
            "odometer_start_km": odo,
            "work_x_front_j": wx[:, 0],
            "work_x_front_sd_j": 0.02 * wx[:, 0],
            "work_x_rear_j": wx[:, 1],
            "work_x_rear_sd_j": 0.05 * wx[:, 1],
            "work_y_front_j": wy_ev[:, 0],
            "work_y_rear_j": wy_ev[:, 1],
            "cornering_stiffness_log_sd": 0.5,
            "cornering_stiffness_source": "type_prior",
            "radius_ratio_front_rear": 1 + y / geom.outer_radius_mm,
            "radius_ratio_front_rear_sd": np.full(n, 3e-5),
            "speed_scale": np.nan,
            "tyre_temperature_c": 20.0,
        }
    )
    rows = []
    for k in (4, 9, n):
        at = odo[k - 1] + interval[k - 1]
        for a, axle in enumerate(("front", "rear")):
            depth = 8.0 - lost[k - 1, a] + 0.05 * rng.standard_normal()
            rows.append({"odometer_km": at, "axle": axle, "depth_mm": depth})
    true_rate = 1000.0 * lost[-1] / (odo[-1] + interval[-1])
    return table, pd.DataFrame(rows), true_rate


def test_history_reads_the_lateral_work_and_its_stiffness_source():
    table, _, _ = cornering_history()
    h = drive_history(table)
    assert h.lateral_source == "type_prior" and h.lateral_log_sd == 0.5
    assert h.work_y_j == pytest.approx(
        table[["work_y_front_j", "work_y_rear_j"]] * h.scale[:, None]
    )
    # a table without the lateral columns has none
    plain = drive_history(table.drop(columns=["work_y_front_j", "work_y_rear_j"]))
    assert plain.lateral_source == "none" and not plain.work_y_j.any()


def test_density_over_the_rear_lateral_scale_peaks_at_the_truth():
    """Fast form of the cornering recovery: with γ at its truth, the readings and the drift put
    the density's peak over the rear axle's lateral-work scale q_r at the true 0.8, and the rear
    wear rate there is the true one."""
    from numpyro.infer.util import log_density

    from tyrebayes.inference.wear.data import WearPriors
    from tyrebayes.inference.wear.history import reading_exposure
    from tyrebayes.inference.wear.history_fit import _ScalePrior, wear_history_model

    table, read, true_rate = cornering_history()
    h = drive_history(table)
    readings = tread_readings(read)
    exposure, pair = reading_exposure(h, readings)
    priors = WearPriors()
    area = float(TreadGeometry().wear_area_mm2)
    args = (h, exposure, pair, np.asarray(readings.depth_mm), False, priors, area)
    scales = _ScalePrior.of(priors, h.lateral_log_sd)
    root_inv = np.linalg.inv(scales.r_root)

    @jax.jit
    def density(z):
        params = {
            "log_gamma_work": np.log(GAMMA),  # the prior median: u's deviation is 0
            "lateral_z": z,
            "sigma_ratio_mm": 0.01,
            "tau": 0.02,
            "initial_depth_mm": np.full(h.n_pairs, 8.0),
            "sigma_depth_mm": 0.05,
        }
        return log_density(wear_history_model, args, {}, params)[0]

    grid = 0.8 * np.exp(np.linspace(-0.4, 0.4, 17))
    dens = [float(density(root_inv @ np.log([0.8, q]))) for q in grid]
    best = grid[int(np.argmax(dens))]
    assert abs(best / 0.8 - 1) < 0.06
    # the rear rate at the peak: γ (Wx + q Wy) per km, against the truth
    rear = GAMMA * (h.work_j[:, 1] + best * h.work_y_j[:, 1]).sum() / 2 / area
    assert 1000.0 * rear / h.total_km == pytest.approx(true_rate[1], rel=0.08)
    # without the lateral work the rear axle would hardly wear
    assert GAMMA * h.work_j[:, 1].sum() / 2 / area * 1000.0 / h.total_km < 0.05 * true_rate[1]


@pytest.mark.slow
def test_the_rear_axles_lateral_wear_rate_is_recovered():
    """Cornering history: the rear axle wears almost only laterally, and its rate is found.

    The evidence's lateral work reads 1.25 times the truth (a soft type-prior c_y); the fit's
    lateral-work scale takes that out through the readings, so the rear rate's 90 % interval
    covers the truth; without the lateral work the rear rate would be ~1/40 of it.
    """
    table, read, true_rate = cornering_history()
    h = drive_history(table)
    readings = tread_readings(read)
    fit = fit_wear_history(
        h, readings, extended=False, num_warmup=150, num_samples=150, num_chains=1, seed=2
    )
    out = wear_history_predictions(fit, h, readings).to_dict()
    for a, axle in enumerate(("front", "rear")):
        lo, hi = out["wear_mm_per_1000km"][axle]["hdi_90"]
        assert lo < true_rate[a] < hi, (axle, lo, true_rate[a], hi)
    assert out["wear_mm_per_1000km"]["rear"]["hdi_90"][0] > 0.5 * true_rate[1]
    assert out["lateral_work"]["cornering_stiffness_source"] == "type_prior"
    assert out["lateral_work"]["share_of_work"]["rear"] > 0.9
    q = out["lateral_work"]["scale"]["rear"]
    assert q["hdi_90"][0] < 0.8 < q["hdi_90"][1]


def test_initial_depths_integrated_out_and_drawn_after_the_chains():
    """The readings' likelihood with each pair's initial depth integrated out equals the joint
    one integrated over d0 on a grid, and the depths drawn after the chains have that grid's
    posterior mean and sd."""
    import numpyro.distributions as dist
    from numpyro.infer.util import log_density
    from scipy.stats import norm

    from tyrebayes.inference.wear.data import WearPriors
    from tyrebayes.inference.wear.history_fit import (
        DEPTH_NOISE_LOG_SD,
        NEW_DEPTH_MM,
        NEW_DEPTH_SD_MM,
        _initial_depths,
        wear_history_model,
    )

    table, _ = synthetic_table(seed=3)
    h = drive_history(table)
    end = float(h.odometer_km[-1] + h.interval_km[-1])
    mid = float(h.odometer_km[10])
    readings = tread_readings(
        pd.DataFrame(
            {
                "odometer_km": [mid, mid, end, end],
                "axle": ["front", "rear", "front", "rear"],
                "depth_mm": [7.6, 7.9, 6.9, 7.7],
            }
        )
    )
    exposure, pair = reading_exposure(h, readings)
    depth = np.asarray(readings.depth_mm)
    area = float(TreadGeometry().wear_area_mm2)
    priors = WearPriors()
    point = {
        "log_gamma_work": np.log(GAMMA),
        "lateral_z": np.zeros(2),
        "sigma_ratio_mm": 0.01,
        "tau": 0.05,
        "sigma_depth_mm": 0.25,
    }
    args = (h, exposure, pair, depth, False, priors, area)
    without = (h, None, None, None, False, priors, area)
    drift = {k: v for k, v in point.items() if k != "sigma_depth_mm"}
    depth_ll = float(log_density(wear_history_model, args, {}, point)[0]) - float(
        log_density(wear_history_model, without, {}, drift)[0]
    )
    noise_prior = dist.LogNormal(np.log(priors.depth_noise_scale_mm), DEPTH_NOISE_LOG_SD)
    depth_ll -= float(noise_prior.log_prob(0.25))
    # the same by a grid over each pair's d0 (pairs are independent given the wear)
    loss = GAMMA / 2.0 / area * h.work_j  # (n, 2) mm per tyre; no lateral work, κ = 0
    lost = np.einsum("mja,ja->m", exposure, loss)
    grid = np.linspace(5.0, 11.0, 6001)
    total, moments = 0.0, {}
    for p in np.unique(pair):
        mine = pair == p
        like = norm.pdf(grid, NEW_DEPTH_MM, NEW_DEPTH_SD_MM) * np.prod(
            norm.pdf(depth[mine][:, None], grid[None, :] - lost[mine][:, None], 0.25), axis=0
        )
        total += np.log(np.trapezoid(like, grid))
        mean = np.trapezoid(grid * like, grid) / np.trapezoid(like, grid)
        sd = np.sqrt(np.trapezoid((grid - mean) ** 2 * like, grid) / np.trapezoid(like, grid))
        moments[int(p)] = (mean, sd)
    assert depth_ll == pytest.approx(total, abs=1e-6)

    draws = 20_000
    samples = {
        "gamma_work": np.full((1, draws), GAMMA),
        "log_lateral_ratio": np.zeros((1, draws, 2)),
        "sigma_depth_mm": np.full((1, draws), 0.25),
    }
    d0 = _initial_depths(samples, h, exposure, pair, depth, area, seed=0)
    assert d0.shape == (1, draws, h.n_pairs)
    for p, (mean, sd) in moments.items():
        assert d0[0, :, p].mean() == pytest.approx(mean, abs=4 * sd / np.sqrt(draws))
        assert d0[0, :, p].std() == pytest.approx(sd, rel=0.03)
