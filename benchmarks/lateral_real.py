"""Lateral inference on real cars: fitted without the lateral velocity, checked against it.

Real logs with a measured lateral velocity (GNSS/INS), in ``../shared/data/real/lateral/``
(evaluation only, never shipped): the Stanford 2014 track log (a mid-engined RWD car at racing
pace) and the Stanford "Niki" VW GTI at the limit (High_Speed, High_Speed2) and turning at walking
pace (Low_Speed, kinematic: nothing is identifiable there, and the fit must say so). They give
V_x and the road-wheel angle, not wheel speeds: the lateral fit runs from what the log has
(``speed_reference``, ``wheel_angle_front``) and never reads the lateral velocity.

The reference is a least-squares fit that does use it: each axle's slip angle from the measured
lateral velocity (α_f = δ − (v_y + l_f r)/V_x, α_r = −(v_y − l_r r)/V_x), its force over the static
load from a_y and ṙ as the model computes it (the vehicle file's J_z), and ρ = c α + b over the
linear range (|ρ| < 0.35, V_x > 8 m/s), both low-passed as the fit's observations are. Both
variables carry noise (the INS lateral velocity, a_y), so that regression's slope is attenuated;
regressing α on ρ instead errs the other way, and the two bound the slope a regression without
either error would give. The bounds are reported beside the reference, and whether the fit's
interval meets them (for K, the bounds' combinations). Also the
real RAV4's highway minute (``tyrebayes/data/comma2k19_rav4_segment.csv``, shipped, MIT): what
the lateral fit says and how wide it is.

Usage: ``python benchmarks/lateral_real.py``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import jax
from _results import figure, write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from _data import niki_lateral_log, rav4_segment_path, stanford_lateral_log  # noqa: E402
from _internal import G  # noqa: E402
from scipy.signal import butter, sosfiltfilt  # noqa: E402

from tyrebayes import load_vehicle  # noqa: E402
from tyrebayes.inference.lateral import (  # noqa: E402
    NoCornering,
    cornering_observations,
    fit_lateral,
)
from tyrebayes.streams import read_stream, validate_stream  # noqa: E402

HERE = Path(__file__).resolve().parent


def _lowpass(x: np.ndarray, rate: float) -> np.ndarray:
    return sosfiltfilt(butter(2, 2.0 / (rate / 2.0), output="sos"), x)


def reference(frame: pd.DataFrame, vehicle) -> dict:
    """Least-squares axle stiffness from the measured lateral velocity (module docstring)."""
    t = frame["time"].to_numpy()
    rate = 1.0 / float(np.median(np.diff(t)))
    vx, vy, r, ay, delta = (
        _lowpass(frame[c].to_numpy(float), rate)
        for c in ("speed_reference", "lateral_velocity", "yaw_rate", "ay", "wheel_angle_front")
    )
    m, jz = float(vehicle.mass_kg), float(vehicle.yaw_inertia_kgm2)
    lf, lr = float(vehicle.cog_to_front_axle_m), float(vehicle.cog_to_rear_axle_m)
    rdot = np.gradient(r, t)
    rho = {"front": ay / G + jz * rdot / (m * G * lr), "rear": ay / G - jz * rdot / (m * G * lf)}
    alpha = {"front": delta - (vy + lf * r) / vx, "rear": -(vy - lr * r) / vx}
    out = {}
    for axle in ("front", "rear"):
        use = (vx > 8.0) & (np.abs(rho[axle]) < 0.35)
        if use.sum() < 200:
            return {"usable": False, "reason": f"{int(use.sum())} samples in the linear range"}
        ones = np.ones(use.sum())
        forward = np.linalg.lstsq(np.c_[alpha[axle][use], ones], rho[axle][use], rcond=None)[0]
        reverse = np.linalg.lstsq(np.c_[rho[axle][use], ones], alpha[axle][use], rcond=None)[0]
        out[f"c_y_{axle}"] = float(forward[0])
        out[f"c_y_{axle}_bounds"] = sorted([float(forward[0]), float(1.0 / reverse[0])])
        out[f"n_{axle}"] = int(use.sum())
    out["understeer_gradient"] = (1.0 / out["c_y_front"] - 1.0 / out["c_y_rear"]) / G
    corners = [
        (1.0 / f - 1.0 / r) / G for f in out["c_y_front_bounds"] for r in out["c_y_rear_bounds"]
    ]
    out["understeer_gradient_bounds"] = [min(corners), max(corners)]
    out["usable"] = True
    return out


def _fit(frame: pd.DataFrame, vehicle, surface: str = "dry") -> dict:
    try:
        obs = cornering_observations(
            frame.drop(columns=["lateral_velocity"], errors="ignore"), vehicle
        )
    except NoCornering as err:
        status = "not identified" if "not identified" in str(err) else "no usable cornering"
        return {"status": status, "reason": str(err)}
    start = time.perf_counter()
    fit = fit_lateral(obs, surface=surface)
    d = fit.to_dict()
    d["fit_s"] = time.perf_counter() - start
    d["status"] = "identified" if d["identified"] else "not identified"
    return d


def _compare(fit: dict, ref: dict) -> dict:
    out = {}
    if fit.get("status") != "identified" or not ref.get("usable"):
        return out
    for key in ("c_y_front", "c_y_rear", "understeer_gradient"):
        lo, hi = fit[key]["hdi_90"]
        out[key] = {
            "fit": fit[key]["mean"],
            "interval": [lo, hi],
            "reference": ref[key],
            "difference": fit[key]["mean"] / ref[key] - 1.0,
            "reference_inside": bool(lo <= ref[key] <= hi),
            "reference_bounds": ref[f"{key}_bounds"],
            "meets_bounds": bool(lo <= ref[f"{key}_bounds"][1] and ref[f"{key}_bounds"][0] <= hi),
        }
    return out


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    logs = {
        "stanford_2014_250lm": (stanford_lateral_log, "stanford_250lm"),
        "niki_gti_high_speed": (lambda: niki_lateral_log("High_Speed"), "niki_gti"),
        "niki_gti_high_speed2": (lambda: niki_lateral_log("High_Speed2"), "niki_gti"),
        "niki_gti_low_speed": (lambda: niki_lateral_log("Low_Speed"), "niki_gti"),
    }
    rows = {}
    for name, (load, vehicle_name) in logs.items():
        vehicle = load_vehicle(HERE / "vehicles" / f"{vehicle_name}.toml")
        frame = load()
        fit = _fit(frame, vehicle)
        ref = reference(frame, vehicle)
        rows[name] = {"fit": fit, "reference": ref, "comparison": _compare(fit, ref)}
        print(name, fit.get("status"), rows[name]["comparison"], flush=True)
    rav4 = load_vehicle("suv_rav4")
    validated = validate_stream(read_stream(rav4_segment_path()), rav4)
    rows["comma2k19_rav4_highway"] = {"fit": _fit(validated.data, rav4), "reference": None}
    print("rav4", rows["comma2k19_rav4_highway"]["fit"].get("status"))
    compared = [c for r in rows.values() for c in (r.get("comparison") or {}).values()]
    inside = sum(c["reference_inside"] for c in compared)
    meets = sum(c["meets_bounds"] for c in compared)
    low = rows["niki_gti_low_speed"]["fit"]["status"]
    figures = [
        figure(
            "real logs: reference stiffness inside the fit's 90 % interval",
            inside / max(len(compared), 1),
            count=len(compared),
            note=f"{inside} of {len(compared)} (c_y front, rear, K over the identified logs)",
        ),
        figure(
            "real logs: fit's 90 % interval meets the reference's errors-in-variables bounds",
            meets / max(len(compared), 1),
            count=len(compared),
            note=f"{meets} of {len(compared)} (the ρ-on-α and α-on-ρ regressions' slopes)",
        ),
        figure(
            "kinematic log (Niki Low_Speed) not identified",
            low != "identified",
            target=("==", True),
            count=1,
            note=f"status: {low}",
        ),
    ]
    for name, row in rows.items():
        for key, c in (row.get("comparison") or {}).items():
            figures.append(
                figure(
                    f"{name}: {key} against the v_y reference",
                    100 * c["difference"],
                    unit="%",
                    count=1,
                    note=(
                        "reference inside the 90 % interval"
                        if c["reference_inside"]
                        else "reference outside the 90 % interval"
                    )
                    + f"; bounds {c['reference_bounds'][0]:.4g}-{c['reference_bounds'][1]:.4g}"
                    + (", met" if c["meets_bounds"] else ", not met"),
                )
            )
    path = write_result("lateral_real", {"logs": rows}, figures=figures)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
