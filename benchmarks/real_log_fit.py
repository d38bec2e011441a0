"""Fit the shipped real RAV4 segment (comma2k19, 60 s) and check the posterior predictive.

Assumptions (stated, not verified by the log):

* vehicle preset ``suv_rav4`` — FWD assumed, mass 1700 kg with driver, nominal radius 0.35 m;
* dry asphalt (California highway, August), tyre temperature = 25 °C (no temperature channel;
  the segment is cut from a longer drive, so the tyres' warm-up is unknown and C_xr carries it);
* the dashcam IMU's mounting offset is estimated by the stream pipeline (ax − dV_x/dt);
* the dashcam IMU's scale factor is estimated against the wheel speeds' dV_x/dt (it reads a_x
  low: 0.79 against GNSS and wheels in ``real_vs_sim.py``) and divided out, its uncertainty
  widening the force-gain prior (``imu_gain`` below);
* the driven-axle slip is relative to the rear wheels (no braking windows are used);
* the log is a steady highway drive: no ABS, so μ_max stays at its prior and says so.

Writes ``benchmarks/results/real_log_fit.json`` (posterior summaries, diagnostics, the
assumptions) and ``real_log_fit.png`` (observed ρ_x against measured slip with the posterior
predictive 50 %/90 % bands of the slip, binned over the measured ρ_x: the model regresses slip
on force, so that is the conditional it predicts).

Usage: ``python benchmarks/real_log_fit.py [--method fast|nuts]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time
from pathlib import Path

import numpyro
from _results import write_result  # noqa: E402

# One JAX device per core, as the ``tyrebayes`` command does: NUTS chains run side by side.
numpyro.set_host_device_count(max(1, min(4, os.cpu_count() or 1)))

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from _data import rav4_segment_path  # noqa: E402

from tyrebayes import (  # noqa: E402
    compute_features,
    fit_tyre,
    load_vehicle,
    observations_from_features,
    read_stream,
    stack_drives,
    validate_stream,
)

RESULTS = Path(__file__).parent / "results"
# The bulleted list under "Assumptions" in the module docstring, one entry per bullet.
ASSUMPTIONS = [" ".join(item.split()) for item in __doc__.split("\n\n")[2][2:].split("\n* ")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", choices=("fast", "nuts"), default="nuts")
    args = parser.parse_args()
    stream = rav4_segment_path()
    vehicle = load_vehicle("suv_rav4")
    features = compute_features(validate_stream(read_stream(stream), vehicle), vehicle)
    imu_gain = features.nuisances.ax_gain
    obs = stack_drives([observations_from_features(features, temperature_c=25.0)], ["dry"])
    kwargs = {"num_chains": 4, "num_samples": 1000} if args.method == "nuts" else {}
    t0 = time.perf_counter()
    fit = fit_tyre(obs, method=args.method, seed=0, **kwargs)
    fit_wall_s = time.perf_counter() - t0
    summary = fit.summary()

    idata = fit.idata
    slip = np.asarray(idata["observed_data"]["slip_obs"])
    rho = np.asarray(idata["observed_data"]["rho_obs"])
    at_limit = np.asarray(idata["constant_data"]["at_limit"])
    # The model regresses slip on force: its posterior predictive of slip_obs is conditional on
    # the measured ρ_x of each window (ρ_obs itself is predicted from the drive's force
    # population only, so binning it over slip would show a flat band that checks nothing).
    pred = np.asarray(idata["posterior_predictive"]["slip_obs"]).reshape(-1, slip.size)
    ok = ~at_limit
    edges = np.quantile(rho[ok], np.linspace(0, 1, 13))
    centres, bands, bin_resid = [], [], []
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        sel = ok & (rho >= lo) & (rho <= hi)
        if sel.sum() < 3:
            continue
        q = np.quantile(pred[:, sel], [0.05, 0.25, 0.5, 0.75, 0.95])
        centres.append(np.median(rho[sel]))
        bands.append(q)
        bin_resid.append(
            {
                "rho_median": float(np.median(rho[sel])),
                "n": int(sel.sum()),
                "slip_obs_mean": float(slip[sel].mean()),
                "slip_pred_median": float(q[2]),
                "mean_residual": float(slip[sel].mean() - np.median(pred[:, sel])),
                "residual_se": float(slip[sel].std() / np.sqrt(sel.sum())),
            }
        )
    q_window = np.quantile(pred[:, ok], [0.05, 0.95], axis=0)
    inside90 = (slip[ok] >= q_window[0]) & (slip[ok] <= q_window[1])
    bands = np.array(bands)
    # Where the model does not fit: mean residual of slip against its predictive median.
    resid = slip[ok] - np.median(pred[:, ok], axis=0)

    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.fill_betweenx(centres, bands[:, 0], bands[:, 4], alpha=0.25, label="predictive 90% (slip)")
    ax.fill_betweenx(centres, bands[:, 1], bands[:, 3], alpha=0.4, label="predictive 50% (slip)")
    ax.plot(bands[:, 2], centres, "k-", lw=1, label="predictive median")
    ax.scatter(slip[ok], rho[ok], s=6, c="C3", alpha=0.6, label="observed windows (0.25 s)")
    ax.set_xlabel("measured slip σ_x of the driven axle [-]")
    ax.set_ylabel("ρ_x = F_x / F_z [-]")
    c = summary["c_x"]
    ax.set_title(
        f"RAV4 comma2k19 segment: C_x = {c['mean']:.0f} ± {c['sd']:.0f}; "
        f"{100 * inside90.mean():.0f}% of windows' slip in the 90% band",
        fontsize=10,
    )
    ax.legend(fontsize=8)
    fig.tight_layout()
    RESULTS.mkdir(exist_ok=True)
    png = RESULTS / "real_log_fit.png"
    tmp = png.with_name(f".{png.name}.{os.getpid()}.tmp.png")
    fig.savefig(tmp, dpi=120)
    os.replace(tmp, png)

    payload = {
        "stream": "tyrebayes/data/comma2k19_rav4_segment.csv",
        "vehicle": "suv_rav4",
        "method": args.method,
        "fit_wall_s_with_compilation": fit_wall_s,
        "load_average": list(os.getloadavg()),
        "assumptions": ASSUMPTIONS,
        "imu_gain": dataclasses.asdict(imu_gain),
        "summary": summary,
        "posterior_predictive": {
            "checked": "slip_obs given the measured rho_x of each window (slip-on-force model)",
            "share_of_windows_in_90pct_band": float(inside90.mean()),
            "binned_by_rho": bin_resid,
            "residual_mean": float(resid.mean()),
            "residual_sd": float(resid.std()),
            "slip_range": [float(slip[ok].min()), float(slip[ok].max())],
            "rho_range": [float(rho[ok].min()), float(rho[ok].max())],
        },
    }
    from _results import to_jsonable as _to_jsonable

    write_result("real_log_fit", _to_jsonable(payload))
    print(json.dumps(_to_jsonable(payload["summary"]["c_x"])), payload["posterior_predictive"])


if __name__ == "__main__":
    main()
