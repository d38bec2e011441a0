"""Power and false discoveries of the criticism's discovery rule on simulated fleets.

For every setting (fleet size, hidden effect and its size, number of decoy columns, noise) many
fleets are simulated with :func:`tyrebayes.simulate.fleet.simulate_fleet` and criticised with
``criticize_table`` (permutation scan, Benjamini-Hochberg at 5 %, ELPD gain > 0). Reported per
setting, each with its Monte Carlo standard error and the number of replicate fleets:

* ``power``: share of fleets whose findings contain the hidden effect's column (binomial se);
* ``scan_power``: share where the scan alone (BH q <= 0.05, before the ELPD confirmation) does;
* ``fdr``: mean over fleets of (false findings) / max(1, findings), the false-discovery rate
  the rule controls (se: sd / sqrt(fleets));
* ``any_false_finding``: share of fleets with at least one false finding;
* ``findings_with_nonpositive_gain``: must be 0 (the rule's guarantee), counted not assumed;
* ``coverage``: share of found effects whose 90 % HDI contains the truth;
* ``seconds_per_fleet`` (shared 2-core machine, other jobs running).

Settings: 26 and 100 sets, 2 and 8 decoy columns (plus the four real covariate columns age,
tread depth, pressure, load index, all candidates), effects: none (Gaussian noise), none with
Student-t(3) noise (heavier tails only), the thesis' aged-tyre effect (0.04 mu per year), half of
it (0.02) and the weak tread-depth effect of issue 25 (0.012 mu per mm).

Targets (issue 25): power >= 0.9 at the aged-tyre effect and >= 0.8 at half of it with 26 sets;
false-discovery rate <= 5 % (every setting).

Run ``python benchmarks/discovery.py [--fleets N]``; ``--real-log`` adds the real RAV4 log's
criticisms (stream, and the per-tyre fit's fit file), ``--fits N`` N hierarchical fleet fits
criticised from their fit files. Results go to ``benchmarks/results/discovery.json`` (atomic).
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _results import RESERVED, write_result  # noqa: E402

from tyrebayes.criticism import criticize_table
from tyrebayes.simulate import THESIS_AGED_TYRE_EFFECT, simulate_fleet

RESULTS = Path(__file__).resolve().parent / "results" / "discovery.json"
MORE_NULL = RESULTS.with_name("discovery_more_null.json")
MACHINE = "CPU machine; timings include whatever else ran on it (see the load averages)"
# Truth of the effect in the reported unit (outcome per unit of the effect's column).
_TRUE_COEF = {"age": lambda s: -s, "tread": lambda s: s}
ALPHA = 0.05


def _settings() -> list[dict]:
    out = []
    for n in (26, 100):
        for nd in (2, 8):
            for eff, size, noise in (
                (None, 0.0, "gaussian"),
                (None, 0.0, "student_t3"),
                ("age", THESIS_AGED_TYRE_EFFECT, "gaussian"),
                ("age", THESIS_AGED_TYRE_EFFECT / 2, "gaussian"),
                ("tread", 0.012, "gaussian"),
            ):
                out.append(
                    {
                        "n_sets": n,
                        "n_decoys": nd,
                        "effect": eff,
                        "effect_size": size,
                        "noise": noise,
                    }
                )
    return out


def _binomial(k: int, n: int) -> dict:
    p = k / n
    return {"value": p, "se": math.sqrt(max(p * (1 - p), 0.0) / n), "count": k, "of": n}


def run_setting(setting: dict, n_fleets: int, seed0: int, n_draws: int, n_perm: int) -> dict:
    """Criticise ``n_fleets`` simulated fleets of one setting and summarise the decisions."""
    eff, size = setting["effect"], setting["effect_size"]
    found_target = scan_target = any_false = nonpositive = covered = covered_n = 0
    fdp, seconds = [], []
    for i in range(n_fleets):
        table, truth = simulate_fleet(
            seed0 + i,
            setting["n_sets"],
            effects=(eff,) if eff else (),
            effect_size=size if eff else None,
            n_decoys=setting["n_decoys"],
            noise=setting["noise"],
        )
        start = time.perf_counter()
        res = criticize_table(
            table, "mu", seed=i, n_draws=n_draws, n_permutations=n_perm, report_all=False
        )
        seconds.append(time.perf_counter() - start)
        target = truth["effect_columns"][eff] if eff else None
        false = [f for f in res.found if f != target]
        fdp.append(len(false) / max(1, len(res.found)))
        any_false += bool(false)
        nonpositive += sum(1 for c in res.candidates if c.found and not c.elpd_gain > 0)
        if target is None:
            continue
        cand = next(c for c in res.candidates if c.covariate == target)
        found_target += target in res.found
        scan_target += cand.q_value <= ALPHA
        if target in res.found:
            lo, hi = cand.effect["hdi_90"]
            covered += lo <= _TRUE_COEF[eff](size) <= hi
            covered_n += 1
    out = dict(setting)
    out.update(
        n_fleets=n_fleets,
        power=_binomial(found_target, n_fleets) if eff else None,
        scan_power=_binomial(scan_target, n_fleets) if eff else None,
        fdr={
            "value": float(np.mean(fdp)),
            "se": float(np.std(fdp, ddof=1) / math.sqrt(n_fleets)),
            "of": n_fleets,
        },
        any_false_finding=_binomial(any_false, n_fleets),
        findings_with_nonpositive_gain=nonpositive,
        coverage=_binomial(covered, covered_n) if covered_n else None,
        seconds_per_fleet=float(np.mean(seconds)),
    )
    return out


def time_26_rows(repeats: int) -> dict:
    """Wall time of the full criticism (every candidate fitted, PPC) and of the CLI on 26 rows."""
    table, _ = simulate_fleet(7, 26, effects=("age",), n_decoys=3)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        criticize_table(table, "mu")
        times.append(time.perf_counter() - start)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "fleet.csv"
        table.to_csv(path, index=False)
        start = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-m", "tyrebayes.cli", "criticize", str(path), "--outcome", "mu"]
            + ["--json"],
            capture_output=True,
            check=True,
        )
        cli = time.perf_counter() - start
    return {
        "function_seconds_median": statistics.median(times),
        "function_seconds_max": max(times),
        "repeats": repeats,
        "cli_seconds": cli,
        "cli_found": json.loads(proc.stdout)["found"],
        "target_seconds": 30.0,
        "machine": MACHINE,
    }


def _decisions(res) -> dict:
    return {
        **res.to_json(),
        "nonpositive_gain_findings": [
            c.covariate for c in res.candidates if c.found and not c.elpd_gain > 0
        ],
    }


def real_log() -> dict:
    """The real RAV4 segment: stream criticism, and the per-tyre fit criticised from its file."""
    from _data import rav4_segment_path

    from tyrebayes import criticize_stream, criticize_tyre_fit, fit_tyre, observations_from_stream

    path = rav4_segment_path()
    out = {}
    for window in (None, 2.0, 5.0):
        res = criticize_stream(path, "suv_rav4", window_s=window)
        key = "default" if window is None else f"{window:g}s"
        out[f"stream_{key}"] = _decisions(res)
        print(f"real log stream ({key}): found {res.found}", flush=True)
    obs = observations_from_stream(path, "suv_rav4")
    start = time.perf_counter()
    fit = fit_tyre(obs, method="fast", seed=0)
    fit_s = time.perf_counter() - start
    with tempfile.TemporaryDirectory() as tmp:
        saved = fit.save(Path(tmp) / "rav4_tyre.nc")
        start = time.perf_counter()
        res = criticize_tyre_fit(saved)
        crit_s = time.perf_counter() - start
    out["tyre_fit_file"] = {
        **_decisions(res),
        "fit": "fit_tyre(observations_from_stream(segment, 'suv_rav4'), method='fast', seed=0)",
        "fit_seconds": fit_s,
        "criticism_seconds": crit_s,
    }
    print(f"real log tyre fit file: found {res.found}", flush=True)
    return out


def fleet_fits(n_fits: int) -> dict:
    """Hierarchical fleet fits (NUTS) criticised from their fit files: age effect and null."""
    from tyrebayes import criticize_fleet_fit, fit_fleet

    rows = []
    for i in range(n_fits):
        eff = ("age",) if i % 2 == 0 else ()
        table, _ = simulate_fleet(7000 + i, 26, effects=eff, n_decoys=2)
        start = time.perf_counter()
        fit = fit_fleet(table, "mu", num_warmup=300, num_samples=300, seed=i)
        fit_s = time.perf_counter() - start
        with tempfile.TemporaryDirectory() as tmp:
            saved = fit.save(Path(tmp) / "fleet.nc")
            start = time.perf_counter()
            res = criticize_fleet_fit(saved, table, seed=i)
            crit_s = time.perf_counter() - start
        age = next(c for c in res.candidates if c.covariate == "age_years")
        row = {
            "seed": 7000 + i,
            "effect": eff[0] if eff else None,
            "converged": fit.converged,
            "found": list(res.found),
            "age_p_value": age.p_value,
            "age_elpd_gain": age.elpd_gain,
            "age_se": age.se,
            "age_effect": age.effect,
            "ppc_outside_0025_0975": [
                k for k, v in res.ppc.items() if not 0.025 <= v["p_value"] <= 0.975
            ],
            "fit_seconds": fit_s,
            "criticism_seconds": crit_s,
        }
        print(f"fleet fit {row}", flush=True)
        rows.append(row)
    with_age = [r for r in rows if r["effect"]]
    null = [r for r in rows if not r["effect"]]
    return {
        "fits": rows,
        "age_found": sum("age_years" in r["found"] for r in with_age),
        "age_fleets": len(with_age),
        "null_with_finding": sum(bool(r["found"]) for r in null),
        "null_fleets": len(null),
        "machine": MACHINE,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleets", type=int, default=200, help="fleets per setting")
    parser.add_argument("--null-fleets", type=int, default=400, help="fleets per null setting")
    parser.add_argument("--draws", type=int, default=1000, help="posterior draws per model")
    parser.add_argument("--permutations", type=int, default=999)
    parser.add_argument("--real-log", action="store_true", help="only add the real RAV4 log")
    parser.add_argument("--fits", type=int, default=0, help="only add N fleet fit files")
    parser.add_argument(
        "--more-null",
        type=int,
        default=0,
        help="only: N more null fleets per 26-set null setting (new seeds), to "
        "discovery_more_null.json",
    )
    args = parser.parse_args(argv)
    if args.more_null:
        rows = [
            run_setting(
                setting,
                args.more_null,
                5_000_000 + 10_000 * k,
                n_draws=args.draws,
                n_perm=args.permutations,
            )
            for k, setting in enumerate(_settings())
            if setting["n_sets"] == 26 and setting["effect"] is None
        ]
        for r in rows:
            print(f"{r['n_decoys']} decoys, {r['noise']}: FDR {r['fdr']}", flush=True)
        payload = {
            "what": "more null fleets (new seeds) for the 26-set null settings of discovery.json",
            "machine": MACHINE,
            "settings": rows,
        }
        print(f"saved {write_result('discovery', payload, path=MORE_NULL)}")
        return 0
    if args.fits or args.real_log:
        added = {}
        if args.real_log:
            added["real_rav4"] = real_log()
        if args.fits:
            added["fleet_fit_files"] = fleet_fits(args.fits)
        # Read only now: the main run may have rewritten the file meanwhile.
        old = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
        payload = {k: v for k, v in old.items() if k not in RESERVED}
        payload.update(added)
        print(f"saved {write_result('discovery', payload, path=RESULTS)}")
        return 0

    rows = []
    start_all = time.perf_counter()
    for k, setting in enumerate(_settings()):
        fleets = args.null_fleets if setting["effect"] is None else args.fleets
        row = run_setting(
            setting, fleets, 1_000_000 + 10_000 * k, n_draws=args.draws, n_perm=args.permutations
        )
        rows.append(row)
        power = "  -  " if row["power"] is None else f"{row['power']['value']:.3f}"
        print(
            f"n={row['n_sets']:>3} decoys={row['n_decoys']} {row['effect'] or 'none':<5} "
            f"size={row['effect_size']:<6g} noise={row['noise']:<10} fleets={fleets}: "
            f"power {power} FDR {row['fdr']['value']:.3f}±{row['fdr']['se']:.3f} "
            f"{row['seconds_per_fleet']:.2f} s/fleet",
            flush=True,
        )
    timing = time_26_rows(repeats=5)

    def pick(n, eff, size):
        return [
            r
            for r in rows
            if r["n_sets"] == n and r["effect"] == eff and abs(r["effect_size"] - size) < 1e-12
        ]

    aged = pick(26, "age", THESIS_AGED_TYRE_EFFECT)
    half = pick(26, "age", THESIS_AGED_TYRE_EFFECT / 2)
    targets = {
        "power_aged_26_sets": {f"{r['n_decoys']} decoys": r["power"] for r in aged},
        "power_aged_target": 0.9,
        "power_aged_met": all(r["power"]["value"] >= 0.9 for r in aged),
        "power_half_aged_26_sets": {f"{r['n_decoys']} decoys": r["power"] for r in half},
        "power_half_target": 0.8,
        "power_half_met": all(r["power"]["value"] >= 0.8 for r in half),
        "fdr_max": max(r["fdr"]["value"] for r in rows),
        "fdr_target": 0.05,
        "fdr_met": all(r["fdr"]["value"] <= 0.05 for r in rows),
        "nonpositive_gain_findings": sum(r["findings_with_nonpositive_gain"] for r in rows),
        "timing_met": timing["cli_seconds"] <= 30.0,
    }
    print(f"targets: {json.dumps(targets)}")
    old = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    payload = {
        "config": {
            "fleets_per_setting": args.fleets,
            "fleets_per_null_setting": args.null_fleets,
            "draws": args.draws,
            "permutations": args.permutations,
            "alpha": ALPHA,
            "machine": MACHINE,
            "total_seconds": time.perf_counter() - start_all,
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        },
        "settings": rows,
        "timing_26_rows": timing,
        "targets": targets,
        **{k: old[k] for k in ("real_rav4", "fleet_fit_files") if k in old},
    }
    print(f"saved {write_result('discovery', payload, path=RESULTS)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
