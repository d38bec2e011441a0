"""The signal pipeline on the real RAV4 log (comma2k19): features, plots and physical checks.

Runs ``read_stream -> validate_stream -> compute_features`` on the shipped 60 s highway segment
with the ``suv_rav4`` vehicle, plots the features to ``benchmarks/results/real_log_features.png``
and checks that they make physical sense:

- V_x from the rear (non-driven) wheels matches the GNSS speed: scale within ±1.5 % (the log's
  wheel speeds were converted with an assumed 0.35 m radius) and, after that scale, within
  0.05 m/s rms (GNSS noise and lag at 20 Hz).
- slip rises with the driven axle's force: correlation > 0.6 and a slope dσ/dρ that gives a
  slip stiffness C_x between 15 and 80 (passenger-car tyres), and more slip under hard
  acceleration (ρ > 0.15) than near free rolling.
- the IMU offset is close to the -0.57 m/s² mean ax the data README reports for a flat road.

It also records the sensor characteristics (noise, quantisation, IMU offset, slip spread at
cruise) that a simulated drive of the same car should reproduce.

Usage: python benchmarks/real_log_features.py [--quick]   (the log is small; --quick is the same)
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib
from _results import write_result  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from _data import rav4_segment_path  # noqa: E402
from _results import save_figure  # noqa: E402

from tyrebayes import load_vehicle  # noqa: E402
from tyrebayes.streams import (  # noqa: E402
    SEGMENT_REGIMES,
    compute_features,
    read_stream,
    speed_error,
    validate_stream,
)

RESULTS = Path(__file__).resolve().parent / "results"
SCALE_TOLERANCE = 0.015
RMS_AFTER_SCALE_TOLERANCE_MPS = 0.05


def _plot(feats, ref, fit, path: Path) -> None:
    t = feats.time_s - feats.time_s[0]
    fig, axes = plt.subplots(5, 1, figsize=(10, 13), constrained_layout=True)
    ax = axes[0]
    ax.plot(t, ref, lw=1, label="GNSS speed_reference")
    ax.plot(t, feats.vx_mps, lw=1, label="V_x rear wheels (R = 0.35 m)")
    ax.plot(t, feats.vx_mps / feats.nuisances.speed_scale, lw=1, ls="--", label="V_x / speed scale")
    ax.set_ylabel("speed [m/s]")
    ax.legend(fontsize=8)
    ax = axes[1]
    ax.plot(t, feats.ax_mps2, lw=0.6, label="IMU ax − offset (0.2 s mean)")
    ax.plot(t, feats.dvx_dt_mps2, lw=1, label="dV_x/dt (0.5 s)")
    ax.set_ylabel("accel. [m/s²]")
    ax.legend(fontsize=8)
    ax = axes[2]
    ax.plot(t, 100 * feats.slip_driven, lw=0.8, label="σ_x front (driven) axle")
    ax.fill_between(
        t,
        100 * (feats.slip_driven - feats.slip_driven_sd),
        100 * (feats.slip_driven + feats.slip_driven_sd),
        alpha=0.3,
        lw=0,
    )
    ax.set_ylabel("slip [%]")
    ax.legend(fontsize=8)
    ax = axes[3]
    ax.plot(t, feats.rho_driven, lw=0.8, label="ρ_x front axle")
    colors = plt.cm.tab10(np.arange(len(SEGMENT_REGIMES)))
    for code, kind in enumerate(SEGMENT_REGIMES):
        m = feats.label == code
        if m.any():
            ax.scatter(t[m], np.full(m.sum(), -0.2), s=2, color=colors[code], label=kind)
    ax.set_ylabel("ρ_x [-]")
    ax.legend(fontsize=7, ncol=4)
    ax = axes[4]
    ok = feats.valid & np.isfinite(feats.rho_driven)
    ax.scatter(feats.rho_driven[ok], 100 * feats.slip_driven[ok], s=2, alpha=0.4)
    grid = np.linspace(np.nanmin(feats.rho_driven[ok]), np.nanmax(feats.rho_driven[ok]), 10)
    ax.plot(grid, 100 * (fit[1] + fit[0] * grid), color="k", label=f"OLS: C_x ≈ {1 / fit[0]:.0f}")
    ax.set_xlabel("ρ_x front axle [-]")
    ax.set_ylabel("σ_x [%]")
    ax.legend(fontsize=8)
    axes[0].set_title("comma2k19 RAV4 segment: tyrebayes.streams features")
    for a in axes[:4]:
        a.set_xlabel("time [s]")
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="same as the full run (60 s log)")
    args = parser.parse_args()
    vehicle = load_vehicle("suv_rav4")
    t0 = time.perf_counter()
    stream = validate_stream(read_stream(rav4_segment_path()), vehicle)
    feats = compute_features(stream, vehicle)
    seconds = time.perf_counter() - t0
    ref = stream.data["speed_reference"].to_numpy(dtype=float)
    err = speed_error(feats, ref)

    ok = feats.valid & ~feats.spin & np.isfinite(feats.rho_driven)
    rho, slip = feats.rho_driven[ok], feats.slip_driven[ok]
    fit = np.polyfit(rho, slip, 1)
    corr = float(np.corrcoef(rho, slip)[0, 1])
    hard, free = rho > 0.15, np.abs(rho) < 0.02
    ax_bins = np.quantile(feats.dvx_dt_mps2[ok], [0.0, 0.25, 0.5, 0.75, 1.0])
    slip_by_accel = [
        float(
            np.mean(
                feats.slip_driven[ok][(feats.dvx_dt_mps2[ok] >= lo) & (feats.dvx_dt_mps2[ok] <= hi)]
            )
        )
        for lo, hi in zip(ax_bins[:-1], ax_bins[1:], strict=True)
    ]
    nuis = feats.nuisances
    cruise = ok & (np.abs(feats.dvx_dt_mps2) < 0.2)
    # IMU gain: regressions in both directions bracket it (each is attenuated by the noise of
    # its regressor: the 0.2 s IMU ax vs the 0.5 s wheel derivative).
    both = ok & np.isfinite(feats.ax_mps2) & np.isfinite(feats.dvx_dt_mps2)
    ax_on_dv = float(np.polyfit(feats.dvx_dt_mps2[both], feats.ax_mps2[both], 1)[0])
    dv_on_ax = float(np.polyfit(feats.ax_mps2[both], feats.dvx_dt_mps2[both], 1)[0])
    checks = {
        "vx_scale_within_1p5pct": abs(err["relative_mean"]) < SCALE_TOLERANCE,
        "vx_rms_after_scale_below_0p05": err["rms_after_scale_mps"] < RMS_AFTER_SCALE_TOLERANCE_MPS,
        "slip_correlates_with_force": corr > 0.6,
        "slip_stiffness_plausible": 15.0 < 1.0 / fit[0] < 80.0,
        "more_slip_when_accelerating_hard": bool(slip[hard].mean() > slip[free].mean() + 0.002),
        "slip_rises_with_acceleration_quartiles": bool(np.all(np.diff(slip_by_accel) > 0)),
        "imu_offset_near_readme": -0.8 < nuis.ax_offset_mps2 < -0.4,
    }
    result = {
        "seconds_read_validate_features": seconds,
        "duration_s": stream.duration_s,
        "sample_rate_hz": stream.sample_rate_hz,
        "notes": list(stream.notes),
        "speed_error": err,
        "slip_vs_rho": {
            "slope": float(fit[0]),
            "intercept": float(fit[1]),
            "c_x_ols": float(1.0 / fit[0]),
            "corr": corr,
            "note": "OLS of σ on ρ: ρ noise is small relative to its range here, σ noise ~2e-4",
            "slip_mean_hard_accel": float(slip[hard].mean()),
            "slip_mean_free_rolling": float(slip[free].mean()),
            "slip_mean_by_accel_quartile": slip_by_accel,
        },
        "segments": feats.segments(),
        "sensor_characteristics": {
            "noise": stream.noise,
            "quantisation": stream.quantisation,
            "ax_offset_mps2": nuis.ax_offset_mps2,
            "ax_offset_sd_mps2": nuis.ax_offset_sd_mps2,
            "pitch_offset_deg": float(np.degrees(nuis.pitch_offset_rad)),
            "ay_offset_mps2": nuis.ay_offset_mps2,
            "ax_gain_bracket": [ax_on_dv, 1.0 / dv_on_ax],
            "rho_offset_sd": nuis.rho_offset_sd,
            "smoothed_noise": nuis.smoothed_noise,
            "radius_ratio": nuis.radius_ratio.tolist(),
            "radius_ratio_sd": nuis.radius_ratio_sd.tolist(),
            "speed_scale": nuis.speed_scale,
            "slip_driven_sd_at_cruise": float(np.std(feats.slip_driven[cruise])),
            "slip_driven_p05_p50_p95": np.quantile(slip, [0.05, 0.5, 0.95]).tolist(),
            "stated_slip_sd_median": float(np.median(feats.slip_driven_sd[ok])),
            "stated_rho_sd_median": float(np.median(feats.rho_driven_sd[ok])),
            "timestamp_jitter_s": float(np.std(np.diff(read_stream(rav4_segment_path())["time"]))),
        },
        "checks": checks,
        "all_checks_pass": all(checks.values()),
    }
    RESULTS.mkdir(parents=True, exist_ok=True)
    _plot(feats, ref, fit, RESULTS / "real_log_features.png")
    write_result("real_log_features", result, quick=args.quick or None)
    print(
        f"RAV4 log: {stream.duration_s:.1f} s at {stream.sample_rate_hz:.1f} Hz "
        f"in {seconds:.2f} s\n"
        f"V_x vs GNSS: scale {100 * err['relative_mean']:+.2f} %, rms {err['rms_mps']:.3f} m/s, "
        f"rms after scale {err['rms_after_scale_mps']:.3f} m/s\n"
        f"slip vs rho: corr {corr:.2f}, C_x (OLS) {1 / fit[0]:.1f}, intercept {fit[1]:.2e}\n"
        f"slip by acceleration quartile: {np.round(slip_by_accel, 5).tolist()}\n"
        f"IMU ax offset {nuis.ax_offset_mps2:.3f} ± {nuis.ax_offset_sd_mps2:.3f} m/s² "
        f"(pitch {np.degrees(nuis.pitch_offset_rad):.2f}°); ax gain between {ax_on_dv:.2f} and "
        f"{1 / dv_on_ax:.2f}\n"
        f"stated noise (0.2 s): slip {np.median(feats.slip_driven_sd[ok]):.2e}, "
        f"rho {np.median(feats.rho_driven_sd[ok]):.3f}; rho offset sd {nuis.rho_offset_sd:.3f}\n"
        f"checks: {checks}\nsaved {RESULTS / 'real_log_features.json'} and .png"
    )
    return 0 if result["all_checks_pass"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
