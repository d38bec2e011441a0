"""Does a fit say when its drive cannot measure C_x? Degenerate drives made from an external one.

The per-tyre fit's adequacy (``inference/tyre/adequacy.py``) has two checks that ask whether the
drive identifies C_x at all: too few slip windows with |ρ_x| ≥ ``EXCITATION_FORCE``, and a C_xr
more than ``MAX_C_XR_PRIOR_SDS`` type-prior sds from the type's median. This benchmark fits
(``fit-tyre --method fast``'s path, default model) drives made from ``e00`` of
``../shared/data/external`` (an independent generator's front-driven car, C_x known):

* ``e00``: the drive as it is (the control: must not be flagged by these checks);
* ``e00_first_60s``: its first minute (little data, but real force changes);
* ``cruise``: ten minutes at a constant 20 m/s on the same time base, each wheel speed the
  constant plus white noise of the drive's own wheel-speed noise, a_x its bias plus noise, no
  steering: no force change at all, so nothing measures C_x. (Not physical in one respect: the
  driven wheels carry no slip for the drag; each 5 s block's slip offset would absorb it.)
* ``e00_declared_rwd``: the drive with its vehicle file saying ``rwd``: the free-rolling front
  wheels read as driven, the driven ones as the speed reference.

And whether the fit questions a surface label its ABS stops contradict (μ_max beyond
``MAX_MU_PRIOR_SDS`` of its surface's prior, or another surface's prior predicting it more than
``exp(MAX_LABEL_LOG_BAYES_FACTOR)`` = 20 times better): ``e00_labelled_snow`` and
``e00_labelled_ice``, the dry drive (truth μ 0.95) fitted with ``--surface snow`` / ``ice``.
For e00 under each of the three labels the online estimator runs too (``tyrebayes online``'s
path): its final C_x and μ_max (with the value the filter holds where it withholds it), the same
label statistics, which it reports as a note, and its prior-conflict check (a tyre coordinate
beyond ``max_prior_z`` of the type prior withholds both values).

Reported per case: C_x (mean, 90 % interval) against the truth, μ_max, ``adequate`` with its
reasons, the exciting windows counted, C_xr's distance from the type prior and μ_max's from its
surface's. Nothing is tuned to these drives: the C_xr and excitation thresholds are the online
estimator's (``OnlineConfig``), set before this benchmark; the μ_max one is the C_xr one.

Usage: ``python benchmarks/identification.py [DIR] [--out FILE]``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import jax
from _data import EXTERNAL, external_drives  # noqa: E402
from _results import write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from _internal import (  # noqa: E402
    EXCITATION_FORCE,
    MAX_C_XR_PRIOR_SDS,
    MAX_LABEL_LOG_BAYES_FACTOR,
    MAX_MU_PRIOR_SDS,
    MIN_EXCITED_WINDOWS,
)

from tyrebayes import (  # noqa: E402
    fit_tyre,
    load_vehicle,
    observations_from_stream,
    online_estimate,
    stream_steps,
    stream_windows,
)

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "identification.json"
WHEELS = ("wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl", "wheel_speed_rr")


def cruise(drive: pd.DataFrame, entry: dict, radius_m: float, seed: int = 0) -> pd.DataFrame:
    """A constant 20 m/s on ``drive``'s time base with the drive's own sensor noise."""
    rng = np.random.default_rng(seed)
    n = len(drive)
    out = pd.DataFrame({"time": drive["time"].to_numpy()})
    for wheel, error in zip(WHEELS, entry["rad_err"], strict=True):
        out[wheel] = 20.0 / (radius_m * error) + rng.normal(0.0, entry["wheel_noise"], n)
    out["ax"] = entry["ax_bias"] + rng.normal(0.0, entry["ax_noise"], n)
    out["ay"] = rng.normal(0.0, entry["ax_noise"], n)
    out["yaw_rate"] = rng.normal(0.0, 2e-3, n)
    out["steering_wheel_angle"] = rng.normal(0.0, 2e-3, n)
    out["ambient_temperature"] = 20.0
    out["speed_reference"] = 20.0 + rng.normal(0.0, 0.05, n)
    return out


def fit_case(
    name: str, stream: Path, vehicle: Path, c_x_true: float | None, surface: str = "dry"
) -> dict:
    obs = observations_from_stream(stream, vehicle, surface=surface)
    t0 = time.perf_counter()
    fit = fit_tyre(obs, method="fast", seed=0)
    wall = time.perf_counter() - t0
    c_x = fit.draws("c_x")
    mu = fit.draws("mu_max")[:, 0]
    summary = fit.summary()
    adequacy = fit.adequacy
    row = {
        "case": name,
        "n_windows": int(obs.n_used),
        "converged": bool(fit.diagnostics.converged),
        "c_x_true": c_x_true,
        "c_x_mean": float(c_x.mean()),
        "c_x_sd": float(c_x.std()),
        "c_x_hdi_90": summary["c_x"]["hdi_90"],
        "c_x_err": None if c_x_true is None else float(c_x.mean() / c_x_true - 1),
        "surface": surface,
        "mu_mean": float(mu.mean()),
        "mu_hdi_90": summary["mu_max"]["hdi_90"],
        "mu_observed": bool(summary["mu_max_observed"]),
        "mu_prior_sds": adequacy.mu_prior_sds,
        "mu_likelier_surface": adequacy.mu_likelier_surface,
        "adequate": bool(adequacy.adequate),
        "adequacy_reasons": list(adequacy.reasons),
        "excited_windows": adequacy.excited_windows,
        "c_xr_prior_sds": adequacy.c_xr_prior_sds,
        "identified_force_range": summary["identified"]["force_range"],
        "fit_wall_s": wall,
    }
    print(
        f"{name:18s} C_x {row['c_x_mean']:7.1f} ± {row['c_x_sd']:6.1f} (true {c_x_true}) "
        f"excited {row['excited_windows']:5d} C_xr {row['c_xr_prior_sds']:+5.1f} sd "
        f"mu {row['mu_mean']:.3f} on {surface} {row['mu_prior_sds']} | "
        f"adequate {row['adequate']} {'; '.join(row['adequacy_reasons'])[:160]}",
        flush=True,
    )
    return row


def online_case(stream: Path, vehicle: Path, surface: str) -> dict:
    """The online estimator over the drive (the command's path): its last step's μ_max."""
    windows = stream_windows(stream, vehicle, surface=surface)
    steps = stream_steps(windows, surface)
    trajectory = online_estimate(steps).trajectory
    last = trajectory.to_dict(steps.n_blocks - 1)
    row = {
        "surface": surface,
        "mu_max": last["mu_max"],
        # What the filter holds, reported or withheld: its last step's mean and 90 % interval.
        "mu_max_filter": [
            float(np.asarray(x)[steps.n_blocks - 1])
            for x in (trajectory.mu_max.mean, trajectory.mu_max.low, trajectory.mu_max.high)
        ],
        "mu_max_prior_sds": last["mu_max_prior_sds"],
        "mu_max_reason": last["mu_max_reason"],
        "mu_max_label_log_bayes_factor": last["mu_max_label_log_bayes_factor"],
        "mu_max_likelier_surface": last["mu_max_likelier_surface"],
        "mu_max_note": last["mu_max_note"],
        "c_x": last["c_x"],
        "c_x_reason": last["reason"],
        "prior_conflict": last["prior_conflict"],
        "n_abs_windows": last["n_abs_windows"],
    }
    print(f"online on {surface}: {row}", flush=True)
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", type=Path, default=EXTERNAL)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    (e00,) = external_drives(args.folder, "e00")
    entry, source, vehicle = e00.truth, e00.path, e00.vehicle_path
    drive = e00.frame()
    vehicle_text = vehicle.read_text()
    radius = load_vehicle(vehicle).wheel_radius_m
    t0 = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        first = folder / "e00_first_60s.parquet"
        drive[drive["time"] < drive["time"].iloc[0] + 60.0].to_parquet(first)
        flat = folder / "cruise.parquet"
        cruise(drive, entry, radius).to_parquet(flat)
        declared_rwd = folder / "declared_rwd.toml"
        declared_rwd.write_text(vehicle_text.replace('drive = "fwd"', 'drive = "rwd"'))
        assert 'drive = "rwd"' in declared_rwd.read_text()
        cases = [
            ("e00", source, vehicle, entry["c_x"]),
            ("e00_first_60s", first, vehicle, entry["c_x"]),
            ("cruise", flat, vehicle, None),
            ("e00_declared_rwd", source, declared_rwd, entry["c_x"]),
            ("e00_labelled_snow", source, vehicle, entry["c_x"], "snow"),
            ("e00_labelled_ice", source, vehicle, entry["c_x"], "ice"),
        ]
        for case in cases:
            rows.append(fit_case(*case))
        online = [online_case(source, vehicle, surface) for surface in ("dry", "snow", "ice")]
    result = {
        "benchmark": "identification",
        "folder": str(args.folder),
        "method": "fast",
        "thresholds": {
            "excitation_force": EXCITATION_FORCE,
            "min_excited_windows": MIN_EXCITED_WINDOWS,
            "max_c_xr_prior_sds": MAX_C_XR_PRIOR_SDS,
            "max_mu_prior_sds": MAX_MU_PRIOR_SDS,
            "max_label_log_bayes_factor": MAX_LABEL_LOG_BAYES_FACTOR,
        },
        "mu_true": entry["mu"],
        "wall_s": time.perf_counter() - t0,
        "load_avg_1min": os.getloadavg()[0],
        "cases": rows,
        "online_e00_by_label": online,
    }
    write_result("identification", result, path=args.out)


if __name__ == "__main__":
    main()
