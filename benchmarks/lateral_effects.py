"""What the simulator's lateral assumptions get wrong, named and measured (issue 54, item 5).

The package's simulator, and a textbook single-track model, assume that the accelerometer reads
the tyres' lateral force, that the steering sensor has no offset, that the tyres answer at once
and that the vehicle file's yaw inertia is right. On drives the package did not make (the
external cornering drives) and on real cars (the Stanford track log and the Niki GTI, from
``lateral_real.py``'s loaders) each assumption is tested by fitting the full lateral model and the
model without that effect (:func:`tyrebayes.criticism.lateral.criticize_lateral_effects`):
the ELPD gain of each effect (its SE inflated by the residuals' correlation) and, where truth
exists, the change in the c_y and understeer-gradient errors.

Usage: ``python benchmarks/lateral_effects.py [--drives l00,l01]``.
"""

from __future__ import annotations

import argparse
import json

import jax
from _results import figure, write_result  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from _data import external_lateral_drives, niki_lateral_log, stanford_lateral_log  # noqa: E402
from _internal import LATERAL_EFFECTS, criticize_lateral_effects  # noqa: E402
from lateral_real import HERE  # noqa: E402

from tyrebayes import cornering_observations, load_vehicle  # noqa: E402

KEYS = ("c_y_front", "c_y_rear", "understeer_gradient")


def _errors(summary: dict, truth: dict | None) -> dict | None:
    if truth is None:
        return None
    return {k: summary[k]["mean"] / truth[k] - 1.0 for k in KEYS}


def _row(name: str, obs, surface: str, truth: dict | None) -> dict:
    result = criticize_lateral_effects(obs, surface=surface)
    gains = []
    for g in result.gains:
        entry = {
            "effect": g.effect,
            "elpd_gain": g.elpd_gain,
            "elpd_gain_se": g.elpd_gain_se,
            "found": g.found,
        }
        errors, with_errors = _errors(g.without, truth), _errors(g.with_effect, truth)
        if errors is not None:
            entry["abs_error_without"] = {k: abs(v) for k, v in errors.items()}
            # with the effect against without it: for an effect the default leaves out, the
            # fit with it added against the default's
            entry["abs_error_change"] = {k: abs(with_errors[k]) - abs(errors[k]) for k in KEYS}
        gains.append(entry)
    print(name, {g["effect"]: (round(g["elpd_gain"], 1), g["found"]) for g in gains}, flush=True)
    return {"log": name, "default_errors": _errors(result.full, truth), "gains": gains}


def _figures(rows: list[dict]) -> list[dict]:
    """One figure per effect: the logs where its gain exceeds 2 SE, its median gain, and the
    median change of the mean |error| (c_y front, rear, K) with it on the external drives.
    A log whose comparison could not be made (a non-finite ELPD) is excluded and named."""
    figures = []
    for effect in LATERAL_EFFECTS:
        entries = {r["log"]: g for r in rows for g in r["gains"] if g["effect"] == effect}
        excluded = {
            log: "non-finite ELPD" for log, g in entries.items() if not np.isfinite(g["elpd_gain"])
        }
        used = [g for log, g in entries.items() if log not in excluded]
        changes = [
            np.mean(list(g["abs_error_change"].values())) for g in used if "abs_error_change" in g
        ]
        figures.append(
            figure(
                f"{effect}: logs where its ELPD gain exceeds 2 SE",
                sum(g["found"] for g in used),
                count=len(used),
                exclusions=excluded,
                note=(
                    f"median ELPD gain {np.median([g['elpd_gain'] for g in used]):.0f}; "
                    f"median change of the mean |error| with it, external drives "
                    f"{100 * float(np.median(changes)):+.1f} points (negative: better)"
                ),
            )
        )
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", default="", help="external drives to fit (default all)")
    parser.add_argument("--no-real", action="store_true", help="leave out the real logs")
    parser.add_argument(
        "--merge",
        action="store_true",
        help="replace these logs' rows in the existing result and keep the others",
    )
    args = parser.parse_args()
    rows = []
    for drive in external_lateral_drives(names=args.drives):
        vehicle = drive.vehicle()
        frame = drive.validated(vehicle).data
        obs = cornering_observations(frame, vehicle)
        rows.append(_row(drive.path.name, obs, drive.truth["surface"], drive.truth))
    real = {
        "stanford_2014_250lm": (stanford_lateral_log, "stanford_250lm"),
        "niki_gti_high_speed": (lambda: niki_lateral_log("High_Speed"), "niki_gti"),
    }
    for name, (load, vehicle_name) in ({} if args.no_real else real).items():
        vehicle = load_vehicle(HERE / "vehicles" / f"{vehicle_name}.toml")
        frame = load().drop(columns=["lateral_velocity"])
        rows.append(_row(name, cornering_observations(frame, vehicle), "dry", None))
    payload = {"logs": rows}
    if args.merge:
        previous = json.loads((HERE / "results" / "lateral_effects.json").read_text())
        new = {r["log"]: r for r in rows}
        merged = [new.pop(r["log"], r) for r in previous["logs"]]
        rows = merged + list(new.values())
        payload = {
            "logs": rows,
            "merged": {
                "rerun": sorted(r["log"] for r in payload["logs"]),
                "kept_from": previous["run"]["revision"],
            },
        }
    path = write_result("lateral_effects", payload, figures=_figures(rows))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
