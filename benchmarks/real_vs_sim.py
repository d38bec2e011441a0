"""Real RAV4 log vs a simulated drive of the ``suv_rav4`` preset at the same speeds.

The real 60 s comma2k19 segment (``tyrebayes/data/comma2k19_rav4_segment.csv``) is replayed: its
GNSS speed and lateral acceleration (yaw rate × speed) become the simulator's planned profile, and
the simulator's RAV4-like sensor model (``SensorModel.rav4_comma2k19()``) logs it at the real log's
mean rate. Both streams then go through the same measurements:

* timing: mean rate, coefficient of variation of the sample interval;
* wheel speeds: quantisation step, white-noise sd (second differences, the pipeline's estimator),
  high-pass residual sd, dominant vibration frequency per axle, left/right correlation per axle;
* IMU: ax/ay/az/yaw-rate noise, the ax offset (ax − dV/dt of GNSS), ax gain against dV/dt;
* slip spread: each wheel's R·Ω over the four-wheel mean (mean and sd), front/rear and
  left/right ratios, and wheel speed over GNSS speed.

Usage: ``python benchmarks/real_vs_sim.py [--quick] [--seeds N]`` (``--quick``: 1 seed). Writes
``benchmarks/results/real_vs_sim.json`` and ``real_vs_sim.png``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import jax
import numpy as np
import pandas as pd
from _results import write_result  # noqa: E402
from scipy.signal import savgol_filter, welch

jax.config.update("jax_enable_x64", True)

from _data import rav4_segment  # noqa: E402

from tyrebayes import load_vehicle  # noqa: E402
from tyrebayes.physics import GRAVITY_MPS2  # noqa: E402
from tyrebayes.simulate import SensorModel, profile_from_trace, simulate_drive  # noqa: E402
from tyrebayes.streams import quantisation_step, white_noise_sd  # noqa: E402

WHEELS = ["wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl", "wheel_speed_rr"]
RESULTS = Path(__file__).resolve().parent / "results"


def _uniform(df: pd.DataFrame, rate: float) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Channels linearly interpolated onto a uniform grid (spectra and derivatives need one)."""
    t = df["time"].to_numpy()
    tu = np.arange(t[0], t[-1], 1.0 / rate)
    out = {}
    for c in df.columns:
        if c == "time":
            continue
        x = df[c].to_numpy(dtype=float)
        ok = np.isfinite(x)
        out[c] = np.interp(tu, t[ok], x[ok])
    return tu, out


def _peak_hz(x: np.ndarray, rate: float, lo: float, hi: float) -> float:
    f, p = welch(x, fs=rate, nperseg=min(512, len(x)))
    band = (f >= lo) & (f <= hi)
    return float(f[band][np.argmax(p[band])])


def stream_metrics(df: pd.DataFrame, radius_m: float) -> dict:
    """Sensor-level statistics of a stream (the same code for the real and the simulated log)."""
    t = df["time"].to_numpy()
    dt = np.diff(t)
    rate = 1.0 / float(np.mean(dt))
    tu, u = _uniform(df, rate)
    m: dict = {
        "duration_s": float(t[-1] - t[0]),
        "sample_rate_hz": rate,
        "dt_cv": float(np.std(dt) / np.mean(dt)),
    }
    wheels = np.stack([u[c] for c in WHEELS], axis=1)
    raw = {c: df[c].to_numpy(dtype=float) for c in WHEELS}
    m["wheel_quantisation_radps"] = [quantisation_step(raw[c]) for c in WHEELS]
    m["wheel_white_noise_radps"] = [white_noise_sd(raw[c]) for c in WHEELS]
    hp = wheels - savgol_filter(wheels, 31, 2, axis=0)
    m["wheel_highpass_sd_radps"] = hp.std(axis=0).tolist()
    m["wheel_vibration_hz_front"] = _peak_hz(hp[:, :2].mean(1), rate, 5.0, 0.45 * rate)
    m["wheel_vibration_hz_rear"] = _peak_hz(hp[:, 2:].mean(1), rate, 5.0, 0.45 * rate)
    m["wheel_highpass_kurtosis"] = (((hp - hp.mean(0)) ** 4).mean(0) / hp.var(0) ** 2).tolist()
    m["wheel_highpass_p999_radps"] = np.quantile(np.abs(hp), 0.999, axis=0).tolist()
    m["wheel_axle_correlation"] = [
        float(np.corrcoef(hp[:, 0], hp[:, 1])[0, 1]),
        float(np.corrcoef(hp[:, 2], hp[:, 3])[0, 1]),
    ]
    for c in ("ax", "ay", "az", "yaw_rate", "steering_wheel_angle"):
        if c in df:
            x = df[c].to_numpy(dtype=float)
            m[f"{c}_white_noise"] = white_noise_sd(x)
            m[f"{c}_highpass_sd"] = float(np.std(u[c] - savgol_filter(u[c], 31, 2)))
            hpc = u[c] - savgol_filter(u[c], 31, 2)
            m[f"{c}_highpass_kurtosis"] = float(np.mean(hpc**4) / np.var(hpc) ** 2)
    m["steering_quantisation_rad"] = quantisation_step(df["steering_wheel_angle"].to_numpy(float))
    # IMU offset and gain against the derivative of the GNSS speed (1 s smoothing both).
    k = int(rate) | 1
    dv = savgol_filter(u["speed_reference"], k, 2, deriv=1, delta=1.0 / rate)
    ax_s = savgol_filter(u["ax"], k, 2)
    gain, offset = np.polyfit(dv, ax_s, 1)
    m["ax_offset_mps2"] = float(np.median(ax_s - dv))
    m["ax_gain_vs_dvdt"] = float(gain)
    m["ax_fit_offset_mps2"] = float(offset)
    m["az_mean_mps2"] = float(np.nanmean(df["az"])) if "az" in df else float("nan")
    m["implied_pitch_deg"] = float(
        np.degrees(np.arcsin(np.clip(m["ax_offset_mps2"] / GRAVITY_MPS2, -1, 1)))
    )
    # Slip spread: R·Ω of each wheel over the four-wheel mean; wheels over GNSS.
    speed = wheels * radius_m
    mean4 = speed.mean(axis=1, keepdims=True)
    moving = mean4[:, 0] > 3.0
    ratio = speed[moving] / mean4[moving]
    m["wheel_ratio_mean"] = ratio.mean(axis=0).tolist()
    m["wheel_ratio_sd"] = ratio.std(axis=0).tolist()
    m["front_over_rear"] = float(np.mean(speed[moving, :2].sum(1) / speed[moving, 2:].sum(1)))
    m["left_over_right_front"] = float(np.mean(speed[moving, 0] / speed[moving, 1]))
    m["left_over_right_rear"] = float(np.mean(speed[moving, 2] / speed[moving, 3]))
    ref = u["speed_reference"][moving]
    m["wheels_over_gnss"] = float(np.median(mean4[moving, 0] / np.maximum(ref, 0.1)))
    m["gnss_change_fraction"] = float(
        np.mean(np.diff(df["speed_reference"].dropna().to_numpy()) != 0)
    )
    m["nan_fraction"] = float(df.drop(columns="time").isna().to_numpy().mean())
    return m


#: What the simulator still does differently, and why (checked against the printed table).
KNOWN_DIFFERENCES = {
    "az_mean_mps2": "sign convention: the real dashcam's z axis points down (-9.66); the simulator "
    "follows DESIGN.md (z up, +9.8).",
    "steering_quantisation_rad": "the real log's steering was interpolated onto the wheel-speed "
    "time base, which hides its CAN resolution; the simulator quantises to 0.1 deg.",
    "steering_wheel_angle_highpass_sd": "real steering contains the driver's corrections; the "
    "replayed profile is smoothed over 1 s.",
    "yaw_rate_highpass_sd": "real yaw rate contains lane-keeping motion above 1 Hz that the 1 s "
    "smoothed replay lacks; the white-noise part matches.",
    "wheel_highpass_kurtosis": "one real minute with three large bumps; the simulated bump "
    "process gives kurtosis 30-50 (real 80-130): heavy-tailed, but less extreme.",
    "ay_highpass_kurtosis": "as for the wheels: fewer extreme lateral shocks in the simulation.",
    "yaw_rate_highpass_kurtosis": "real yaw and steering include brief driver corrections; the "
    "simulated gyro and steering noise is Gaussian (also steering_wheel_angle_highpass_kurtosis).",
    "gnss_change_fraction": "matched by SensorModel(gnss_hold=False); the default holds 20 Hz "
    "fixes.",
    "ax_gain_vs_dvdt": "the real dashcam reads ax at 0.79 of the acceleration (against GNSS and "
    "wheel derivatives alike); reproduced by ax_gain=0.79 in the RAV4 preset only - the default "
    "sensor has gain 1.",
}


def compare(real: dict, sims: list[dict]) -> dict:
    """Per metric: real value, simulated mean ± sd over seeds, and sim/real ratio for scalars."""
    out = {}
    for key, rv in real.items():
        sv = [s[key] for s in sims]
        arr = np.asarray(sv, dtype=float)
        entry = {
            "real": rv,
            "sim_mean": arr.mean(axis=0).tolist(),
            "sim_sd": arr.std(axis=0).tolist(),
        }
        if np.ndim(rv) == 0 and np.isfinite(rv) and abs(rv) > 1e-12:
            entry["ratio"] = float(arr.mean() / rv)
        out[key] = entry
    return out


def _plot(real_df, sim_df, path: Path, radius: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    for df, name, col in ((real_df, "real", "C0"), (sim_df, "sim", "C1")):
        t = df["time"].to_numpy()
        axes[0, 0].plot(t, df["wheel_speed_rl"] * radius, col, lw=0.6, label=f"{name} R·Ω_rl")
        axes[0, 0].plot(t, df["speed_reference"], col, lw=1.2, ls="--", label=f"{name} GNSS")
        rate = 1 / np.mean(np.diff(t))
        tu, u = _uniform(df, rate)
        for c, ls in (("wheel_speed_fl", "-"), ("wheel_speed_rl", ":")):
            hp = u[c] - savgol_filter(u[c], 31, 2)
            f, p = welch(hp, fs=rate, nperseg=512)
            axes[0, 1].semilogy(f, p, col, ls=ls, lw=0.9, label=f"{name} {c[-2:]}")
        axes[1, 0].plot(t, df["ax"], col, lw=0.4, alpha=0.7, label=f"{name} ax")
        w = df[WHEELS].to_numpy() * radius
        ratio = w / w.mean(axis=1, keepdims=True)
        axes[1, 1].hist(ratio[:, 0] - 1, bins=80, histtype="step", color=col, label=f"{name} fl")
        axes[1, 1].hist(
            ratio[:, 2] - 1, bins=80, histtype="step", color=col, ls=":", label=f"{name} rl"
        )
    axes[0, 0].set(xlabel="time [s]", ylabel="speed [m/s]", title="speed: wheel vs GNSS")
    axes[0, 1].set(xlabel="Hz", ylabel="PSD [(rad/s)²/Hz]", title="wheel-speed high-pass spectrum")
    axes[1, 0].set(xlabel="time [s]", ylabel="ax [m/s²]", title="IMU ax (offset = pitch + bias)")
    axes[1, 1].set(xlabel="R·Ω / 4-wheel mean − 1", ylabel="count", title="slip spread per wheel")
    for a in axes.flat:
        a.legend(fontsize=7)
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one simulated seed")
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args(argv)
    n_seeds = 1 if args.quick else args.seeds

    vehicle = load_vehicle("suv_rav4")
    radius = vehicle.wheel_radius_m
    real_df = rav4_segment()
    real = stream_metrics(real_df, radius)
    rate = round(real["sample_rate_hz"])
    # Replay the real speeds and lateral accelerations; grade unknown (0).
    t = real_df["time"].to_numpy()
    ay = real_df["yaw_rate"].to_numpy() * real_df["speed_reference"].to_numpy()
    planned = profile_from_trace(
        t, real_df["speed_reference"].to_numpy(), sample_rate_hz=rate, ay_mps2=ay, smoothing_s=1.0
    )
    duration = len(planned.time_s) / rate
    sims, sim_df, timings = [], None, []
    for seed in range(n_seeds):
        start = time.perf_counter()
        df, truth = simulate_drive(
            seed,
            "suv_rav4",
            "all_season",
            duration_s=duration,
            sample_rate_hz=rate,
            surface="dry",
            ambient_c=20.0,
            sensor=SensorModel.rav4_comma2k19(),
            planned=planned,
        )
        timings.append(time.perf_counter() - start)
        sims.append(stream_metrics(df, radius))
        sim_df = sim_df if sim_df is not None else df
    table = compare(real, sims)
    result = {
        "description": __doc__.splitlines()[0],
        "n_seeds": n_seeds,
        "sensor_model": "SensorModel.rav4_comma2k19()",
        "sample_rate_hz": rate,
        "simulate_seconds": timings,
        "metrics": table,
        "outside_factor_1.33": sorted(
            k for k, e in table.items() if "ratio" in e and not 0.75 <= e["ratio"] <= 1.33
        ),
        "known_differences": KNOWN_DIFFERENCES,
    }
    RESULTS.mkdir(parents=True, exist_ok=True)
    out = write_result("real_vs_sim", result, quick=args.quick or None)
    _plot(real_df, sim_df, RESULTS / "real_vs_sim.png", radius)

    print(f"real vs simulated ({n_seeds} seed(s)), suv_rav4 at the real speeds, {rate} Hz")
    print(f"{'metric':34s} {'real':>28s} {'simulated':>28s}")
    for key, e in table.items():

        def fmt(x):
            if isinstance(x, list):
                return "[" + ", ".join(f"{v:.4g}" for v in x) + "]"
            return f"{x:.4g}"

        print(f"{key:34s} {fmt(e['real']):>28s} {fmt(e['sim_mean']):>28s}")
    print(
        "scalar metrics off by more than a factor 1.33:", ", ".join(result["outside_factor_1.33"])
    )
    for key, why in KNOWN_DIFFERENCES.items():
        print(f"  {key}: {why}")
    print(f"wrote {out} and {out.with_suffix('.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
