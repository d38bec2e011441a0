"""CPU seconds per drive-hour of the fleet run's windows-and-summary step, before and after.

The step (``tyrebayes.batch.drive_stage._windows_and_summary`` after ``compute_features``: tyre
temperature, windowed observations with the force-density EM, windows table, drive summary) is
timed on the same simulated one-hour drives for two versions of the package: this checkout
("after") and git revision ``--before`` ("before", extracted with ``git archive`` into a
temporary folder, as ``stream_stage_speed.py`` does). Each version runs in a fresh
single-threaded process (OMP one thread, XLA without its Eigen thread pool, as a fleet
worker), every drive once to compile and warm up and then ``--repeats`` more times; a drive's
figure is its fastest repeat, the total is the sum over drives divided by the drive-hours.

Results compared: E[ρ_true | ρ_obs] = ρ + η² s of every slip window (``rho_score`` of the
windows table), after against before, as |difference| / η (the window's noise sd): max, 99th
percentile and rms over windows, max per drive; and the fast tyre fit of each drive's windows
alone (``fit_tyre``, not timed), |ΔC_xr| in units of the before fit's posterior sd. Beside
them the distance of each version from a longer plain-EM run of the before code
(``--reference-steps`` EM steps, tolerance 1e-10): how far the step limit leaves either from
the maximum-likelihood mixture both head for (E[ρ_true | ρ_obs] and the mean log-likelihood
per window of each drive's mixture).

Usage: ``python benchmarks/windows_step_speed.py [--before REV] [--drives N] [--repeats N]
[--result PATH]`` (``--before`` defaults to 3e89a9c, the last revision with the plain EM). Two
results are kept: ``windows_step_speed.json``, the accelerated EM against the plain one (the
defaults), and ``windows_step_float32.json``, the EM's per-window arithmetic in float32 against
float64 (``--before 2a47096 --drives 6 --result benchmarks/results/windows_step_float32.json``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _results import write_result  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).parent))
from _revisions import package_at, run_child  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results" / "windows_step_speed.json"
TYPES = ("winter", "all_season", "summer")
SURFACES = ("dry", "wet", "snow")

_CHILD = r"""
import json, sys, time
import numpy as np
import tyrebayes
import tyrebayes.inference.tyre.force_density as force_density
from tyrebayes.batch.drive_stage import _windows_and_summary
from tyrebayes.batch.manifest import read_manifest
from tyrebayes.batch.settings import RunSettings

manifest, out, repeats, em_steps = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
if em_steps:
    force_density._MAX_ITERATIONS, force_density._TOLERANCE = em_steps, 1e-10
em_runs = []
plain = force_density.deconvolve_forces

def counted(rho, noise_sd, *args, **kwargs):
    mixture = plain(rho, noise_sd, *args, **kwargs)
    total = mixture.variances + np.asarray(noise_sd)[:, None] ** 2
    density = mixture.weights * np.exp(-0.5 * (np.asarray(rho)[:, None] - mixture.means) ** 2
                                       / total) / np.sqrt(2 * np.pi * total)
    log_lik = float(np.mean(np.log(np.sum(density, axis=1))))
    em_runs.append((int(mixture.iterations), bool(mixture.converged), log_lik))
    return mixture

force_density.deconvolve_forces = counted
settings, drives = RunSettings(), []
for item in read_manifest(manifest):
    cpu = []
    for _ in range(repeats + 1):
        em_runs.clear()
        table, row, steps = _windows_and_summary(item, settings)
        cpu.append(steps["windows_and_summary"])
    slip = ~table["at_limit"].to_numpy()
    table.to_parquet(f"{out}/{item.drive_id}.windows.parquet")
    np.savez(f"{out}/{item.drive_id}.npz", **{
        c: table[c].to_numpy()[slip] for c in ("rho", "rho_sd", "rho_score", "time_s")})
    drives.append({"drive_id": item.drive_id, "duration_s": float(row["duration_s"]),
                   "windows": int(len(table)), "slip_windows": int(slip.sum()),
                   "first_cpu_s": cpu[0], "cpu_s": min(cpu[1:]) if repeats else cpu[0],
                   "em_iterations": em_runs[-1][0], "em_converged": em_runs[-1][1],
                   "em_mean_log_lik": em_runs[-1][2]})
# The fast tyre fit of each drive's windows alone (not timed): what the score change does to C_xr.
if not em_steps:
    import pandas as pd
    from tyrebayes.batch.settings import configure_jax
    from tyrebayes.batch.tyre_set_stage import pad_size
    from tyrebayes.batch.windows import drives_from_windows
    from tyrebayes.inference.tyre.data import stack_drives
    from tyrebayes.inference.tyre.fit import fit_tyre

    configure_jax(sys.argv[5])
    # The tyre-curve keyword is ``kind`` in revisions before the API's one dialect.
    import inspect
    curve = "model" if "model" in inspect.signature(fit_tyre).parameters else "kind"
    for drive in drives:
        table = pd.read_parquet(f"{out}/{drive['drive_id']}.windows.parquet")
        windows, surfaces = drives_from_windows(table)
        obs = stack_drives(windows, surfaces, pad_to=pad_size(len(table)))
        fit = fit_tyre(obs, method="fast", seed=settings.seed, **{curve: settings.model})
        summary = fit.summary()
        drive["c_xr"] = float(summary["c_xr"]["mean"])
        drive["c_xr_sd"] = float(summary["c_xr"]["sd"])
print(json.dumps({"drives": drives, "package": tyrebayes.__file__}))
"""

_ENV = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false",
}


def _measure(
    manifest: Path, out: Path, code: Path | None, repeats: int, em_steps: int, cache: Path
) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    load = os.getloadavg()
    start = time.perf_counter()
    measured = run_child(_CHILD, [manifest, out, repeats, em_steps, cache], code, _ENV)
    hours = sum(d["duration_s"] for d in measured["drives"]) / 3600.0
    measured |= {
        "drive_hours": hours,
        "cpu_s_per_drive_hour": sum(d["cpu_s"] for d in measured["drives"]) / hours,
        "em_converged_drives": sum(d["em_converged"] for d in measured["drives"]),
        "em_iterations_total": sum(d["em_iterations"] for d in measured["drives"]),
        "wall_seconds": time.perf_counter() - start,
        "load_average_at_start": load,
        "load_average_at_end": os.getloadavg(),
    }
    return measured


def _make_drives(folder: Path, n_drives: int, seed: int) -> Path:
    import pandas as pd

    from tyrebayes.simulate import simulate_tyre_set_drives, write_drive

    rows = []
    for k in range(n_drives):
        ((df, truth),) = simulate_tyre_set_drives(
            seed * 1000 + k,
            "compact_fwd",
            TYPES[k % len(TYPES)],
            n_drives=1,
            duration_s=3600.0,
            surfaces=SURFACES[k % len(SURFACES)],
        )
        path = folder / f"drive{k:02d}.parquet"
        write_drive(df, truth, path)
        rows.append(
            {
                "path": path.name,
                "vehicle": "compact_fwd",
                "tyre_set_id": f"set{k:02d}",
                "tyre_type": TYPES[k % len(TYPES)],
                "surface": truth.surface,
                "ambient_c": truth.ambient_c,
            }
        )
    manifest = folder / "manifest.csv"
    pd.DataFrame(rows).to_csv(manifest, index=False)
    return manifest


def _corrected(folder: Path, drive_id: str) -> tuple[np.ndarray, np.ndarray]:
    """E[ρ_true | ρ_obs] of a drive's slip windows, and their noise sd η."""
    d = np.load(folder / f"{drive_id}.npz")
    return d["rho"] + d["rho_sd"] ** 2 * d["rho_score"], d["rho_sd"]


def _difference(a: Path, b: Path, drive_ids: list[str]) -> dict:
    """|E_a − E_b| / η over every slip window of the drives: max, 99th percentile, rms."""
    per_drive, pooled = [], []
    for drive_id in drive_ids:
        (ea, sd), (eb, _) = _corrected(a, drive_id), _corrected(b, drive_id)
        z = np.abs(ea - eb) / sd
        per_drive.append(float(z.max()))
        pooled.append(z)
    z = np.concatenate(pooled)
    return {
        "windows": int(z.size),
        "max_sd": float(z.max()),
        "p99_sd": float(np.quantile(z, 0.99)),
        "rms_sd": float(np.sqrt(np.mean(z**2))),
        "max_sd_per_drive": per_drive,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", default="3e89a9c", help="git revision to compare with")
    parser.add_argument("--drives", type=int, default=10, help="simulated one-hour drives")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--seed", type=int, default=23)
    parser.add_argument(
        "--reference-steps", type=int, default=10_000, help="plain-EM steps of the reference"
    )
    parser.add_argument("--result", type=Path, default=RESULTS, help="where the JSON goes")
    args = parser.parse_args()

    revision = subprocess.run(
        ["git", "rev-parse", args.before], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.strip()
    results: dict = {
        "before_revision": revision,
        "repeats": args.repeats,
        "cpu_count": os.cpu_count(),
        "note": "shared 2-core machine (other helpers running): CPU time of one single-threaded "
        "process per version, fastest repeat per drive after a warm-up run; load averages "
        "recorded",
    }
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        start = time.perf_counter()
        manifest = _make_drives(folder, args.drives, args.seed)
        results["simulate_seconds"] = time.perf_counter() - start
        before_code = package_at(revision, folder / "before")
        runs = {
            "after": (None, args.repeats, 0),
            "before": (before_code, args.repeats, 0),
            "reference": (before_code, 0, args.reference_steps),
        }
        for name, (code, repeats, em_steps) in runs.items():
            results[name] = _measure(
                manifest, folder / name, code, repeats, em_steps, folder / "jax_cache"
            )
            print(name, json.dumps({k: v for k, v in results[name].items() if k != "drives"}))
        drive_ids = [d["drive_id"] for d in results["after"]["drives"]]
        results["reference"]["em_steps"] = args.reference_steps
        results["drives"] = len(drive_ids)
        results["drive_hours"] = results["after"]["drive_hours"]
        results["speedup"] = (
            results["before"]["cpu_s_per_drive_hour"] / results["after"]["cpu_s_per_drive_hour"]
        )
        results["mean_log_lik_below_reference"] = {
            name: [
                ref["em_mean_log_lik"] - d["em_mean_log_lik"]
                for d, ref in zip(
                    results[name]["drives"], results["reference"]["drives"], strict=True
                )
            ]
            for name in ("before", "after")
        }
        gaps = results["mean_log_lik_below_reference"]
        results["drives_after_at_least_as_likely_as_before"] = sum(
            a <= b for a, b in zip(gaps["after"], gaps["before"], strict=True)
        )
        after, before = results["after"]["drives"], results["before"]["drives"]
        results["c_xr_difference_after_vs_before_in_sd"] = [
            abs(a["c_xr"] - b["c_xr"]) / b["c_xr_sd"] for a, b in zip(after, before, strict=True)
        ]
        results["score_difference_after_vs_before"] = _difference(
            folder / "after", folder / "before", drive_ids
        )
        results["score_difference_before_vs_reference"] = _difference(
            folder / "before", folder / "reference", drive_ids
        )
        results["score_difference_after_vs_reference"] = _difference(
            folder / "after", folder / "reference", drive_ids
        )
    summary = (
        "speedup",
        "mean_log_lik_below_reference",
        "drives_after_at_least_as_likely_as_before",
        "c_xr_difference_after_vs_before_in_sd",
    )
    for key in (*summary, *(k for k in results if k.startswith("score_difference"))):
        print(key, json.dumps(results[key]))
    print(f"saved {write_result('windows_step_speed', results, path=args.result)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
