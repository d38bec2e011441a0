"""Round trip: simulated drive → file (CSV, Parquet, MDF4) → streams pipeline → features vs truth.

The pipeline uses nominal wheel radii and estimates the IMU offset from ax − dV_x/dt, exactly as it
would on a real car; so the truth predicts its systematic errors, and the tests check those
predictions rather than loose bounds:

* V_x from the non-driven (rear) wheels is off by the rear radius error:
  V̂/V − 1 = 1/(1 + ε̄_rear) − 1;
* the driven-axle slip is off by the slip offset difference of the driven and non-driven wheels;
* ρ_x absorbs the drive's mean road grade into the estimated IMU offset: ρ̂ − ρ ≈ −θ̄ m g / F_z,front.

Tolerances are 3–5× the largest deviation from these predictions over seeds 0–5 at 180 s
(measured: V within 1e-4 relative, slip within 9e-5, ρ within 0.007). The pipeline's claimed slip
noise is ~1.4× smaller than the actual scatter (vibration and bumps are not white), hence the
factor-of-2 band on that ratio.
"""

from __future__ import annotations

import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.physics.vehicle import GRAVITY_MPS2
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.simulate.drive_io import read_drive_truth, write_drive
from tyrebayes.streams import read_stream, validate_stream
from tyrebayes.streams.features import compute_features


def _mad(x: np.ndarray) -> float:
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


@pytest.fixture(scope="module")
def drive():
    return simulate_drive(0, "compact_fwd", "all_season", duration_s=180.0, ambient_c=10.0)


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".mf4"])
def test_pipeline_recovers_truth(tmp_path, drive, suffix):
    df, _ = drive
    path = tmp_path / f"drive{suffix}"
    write_drive(df, drive[1], path)
    truth = read_drive_truth(path)  # the truth as a user would load it
    vehicle = load_vehicle("compact_fwd")
    feats = compute_features(validate_stream(read_stream(path), vehicle), vehicle)

    t = feats.time_s
    vx = np.interp(t, truth.time_s, truth.vx_mps)
    slip = np.interp(t, truth.time_s, truth.slip_driven)
    rho = np.interp(t, truth.time_s, truth.rho_x_driven)
    ax = np.interp(t, truth.time_s, truth.ax_mps2)
    grade = np.interp(t, truth.time_s, truth.grade_rad)
    # Moving, no hard manoeuvre (braking splits the force by a brake balance the pipeline assumes).
    ok = (
        feats.valid
        & (vx > 3.0)
        & (np.abs(ax) < 1.5)
        & np.isfinite(feats.slip_driven)
        & np.isfinite(feats.rho_driven)
    )
    assert ok.sum() > 0.8 * len(t)

    # V_x: bias predicted by the rear radius errors (rear wheels are the non-driven ones).
    rel = np.median(feats.vx_mps[ok] / vx[ok] - 1.0)
    expected_rel = 1.0 / (1.0 + truth.radius_error[2:].mean()) - 1.0
    assert rel == pytest.approx(expected_rel, abs=3e-4)
    assert _mad(feats.vx_mps[ok] - vx[ok]) < 0.05  # m/s, after the 0.2 s smoothing

    # Slip: offset predicted by the per-wheel slip offsets; scatter as the pipeline says.
    err = feats.slip_driven[ok] - slip[ok]
    expected_offset = truth.slip_offset[:2].mean() - truth.slip_offset[2:].mean()
    assert np.median(err) == pytest.approx(expected_offset, abs=3e-4)
    claimed = float(np.median(feats.slip_driven_sd[ok]))
    assert 0.5 < _mad(err) / claimed < 2.0

    # rho_x: the mean grade hides in the IMU offset estimate; otherwise tight and correlated.
    err_rho = feats.rho_driven[ok] - rho[ok]
    fz_front = vehicle.mass_kg * GRAVITY_MPS2 * vehicle.cog_to_rear_axle_m / vehicle.wheelbase_m
    expected_rho = -np.mean(grade[ok]) * vehicle.mass_kg * GRAVITY_MPS2 / fz_front
    assert np.median(err_rho) == pytest.approx(expected_rho, abs=0.02)
    assert _mad(err_rho) < 0.04
    assert np.corrcoef(feats.rho_driven[ok], rho[ok])[0, 1] > 0.9

    # The injected noise is what the pipeline measures: yaw-rate white noise 1.5 mrad/s.
    assert feats.noise["yaw_rate"] == pytest.approx(0.0015, rel=0.2)
