"""The fleet model's NUTS fit: convergence at two sampler settings, and what a refit compiles.

Run: ``python benchmarks/fleet_nuts.py [--fleets N]``. Saves ``benchmarks/results/fleet_nuts.json``.

1. Convergence: ``fit_fleet`` on ``--fleets`` simulated snow fleets of 120 sets (type mix
   40/30/30 %, seeds 11, 12, ...; ``tyrebayes.simulate.fleet``), 2 chains on 2 CPU devices, at the
   former defaults (500 warm-up steps, 500 draws, target acceptance 0.9) and the current ones
   (``fit_fleet``'s signature): how many fits :data:`tyrebayes.inference.result.POLICY` judges
   converged, their divergences, largest R-hat and smallest bulk ESS.
2. Compilation: wall time of the first fit in this process (compiles the sampler; with an empty
   persistent cache) against the refits of other fleets of the same shape (the sampler's
   program takes the data as arguments, ``tyrebayes/inference/nuts.py``).
"""

from __future__ import annotations

import argparse
import inspect
import os
import tempfile
import time

import numpyro
from _results import write_result  # noqa: E402

numpyro.set_host_device_count(2)

import jax  # noqa: E402
import numpy as np  # noqa: E402
from _internal import enable_compilation_cache  # noqa: E402

from tyrebayes import fit_fleet  # noqa: E402
from tyrebayes.simulate import simulate_fleet  # noqa: E402

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")
SHARES = {"winter": 0.4, "all_season": 0.3, "summer": 0.3}
FORMER = {"num_warmup": 500, "num_samples": 500, "target_accept": 0.9}


def _current() -> dict:
    params = inspect.signature(fit_fleet).parameters
    return {k: params[k].default for k in FORMER}


def _run(settings: dict, seeds: list[int]) -> dict:
    rows = []
    for seed in seeds:
        table, _ = simulate_fleet(seed, 120, type_shares=SHARES)
        start = time.perf_counter()
        fit = fit_fleet(table, seed=3, num_chains=2, **settings)
        d = fit.diagnostics
        rows.append(
            {
                "seed": seed,
                "seconds": time.perf_counter() - start,
                "converged": bool(d.converged),
                "reasons": list(d.reasons),
                "divergences": int(d.divergences),
                "r_hat_max": float(d.r_hat_max),
                "ess_bulk_min": float(d.ess_bulk_min),
            }
        )
        print(settings, rows[-1])
    return {
        "settings": settings,
        "n_fits": len(rows),
        "n_converged": sum(r["converged"] for r in rows),
        "n_with_divergences": sum(r["divergences"] > 0 for r in rows),
        "r_hat_max_median": float(np.median([r["r_hat_max"] for r in rows])),
        "ess_bulk_min_median": float(np.median([r["ess_bulk_min"] for r in rows])),
        "first_fit_seconds": rows[0]["seconds"],
        "refit_seconds_median": float(np.median([r["seconds"] for r in rows[1:]])),
        "fits": rows,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fleets", type=int, default=16)
    args = parser.parse_args()
    jax.config.update("jax_enable_x64", True)
    seeds = list(range(11, 11 + args.fleets))
    with tempfile.TemporaryDirectory() as cache:
        enable_compilation_cache(cache)  # empty: the first fit of each setting compiles
        runs = {"former_defaults": _run(FORMER, seeds), "defaults": _run(_current(), seeds)}
    result = {
        "benchmark": "fleet_nuts",
        "fleet": {"sets": 120, "type_shares": SHARES, "surface": "snow", "seeds": seeds},
        "chains": 2,
        "devices": jax.local_device_count(),
        **runs,
        "machine": {"cpu_count": os.cpu_count(), "load_average_1min": os.getloadavg()[0]},
    }
    path = write_result("fleet_nuts", result)
    for name, run in runs.items():
        print(
            f"{name}: {run['n_converged']}/{run['n_fits']} converged, "
            f"{run['n_with_divergences']} with divergences; first fit "
            f"{run['first_fit_seconds']:.1f} s, refit {run['refit_seconds_median']:.1f} s"
        )
    print(f"saved {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
