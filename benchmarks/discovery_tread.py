"""Issue 25's miss, measured: a weak tread-depth effect on snow friction among decoys.

Ten fleet tables of 36 sets (``simulate_fleet(100 + i, 36, effects=("tread",), n_decoys=4)``:
mu rises 0.012 per mm of tread depth; age, pressure, load index and four decoy columns carry no
effect) are criticised with ``criticize_table``; reported per table: the findings, the tread
candidate's p-value, ELPD gain and SE, and how many tables found it.

Run ``python -m benchmarks discovery_tread``; results go to
``benchmarks/results/discovery_tread.json`` (``discovery_tread_<label>.json`` with ``--label``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from _results import write_result  # noqa: E402

from tyrebayes.criticism import criticize_table
from tyrebayes.simulate import simulate_fleet

RESULTS = Path(__file__).resolve().parent / "results"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--label", default="", help="suffix of the JSON file (a variant run)")
    parser.add_argument("--tables", type=int, default=10)
    args = parser.parse_args(argv)
    rows = []
    start = time.perf_counter()
    for i in range(args.tables):
        table, _ = simulate_fleet(100 + i, 36, effects=("tread",), n_decoys=4)
        res = criticize_table(table, "mu", seed=i)
        cand = next(c for c in res.candidates if c.covariate == "tread_depth_mm")
        row = {
            "seed": 100 + i,
            "found": list(res.found),
            "tread_p_value": float(cand.p_value),
            "tread_elpd_gain": float(cand.elpd_gain),
            "tread_se": float(cand.se),
            "tread_effect": cand.effect,
        }
        print(row, flush=True)
        rows.append(row)
    hits = sum("tread_depth_mm" in r["found"] for r in rows)
    payload = {
        "setting": "36 sets, tread effect 0.012 mu per mm, 4 decoys + age/pressure/load columns",
        "n_tables": args.tables,
        "found_tread": hits,
        "false_findings": sum(any(f != "tread_depth_mm" for f in r["found"]) for r in rows),
        "seconds": time.perf_counter() - start,
        "machine": "shared 2-core CPU machine (other jobs running)",
        "tables": rows,
    }
    print(f"tread effect found in {hits} of {args.tables} tables")
    name = f"discovery_tread_{args.label}" if args.label else "discovery_tread"
    print(f"saved {write_result('discovery_tread', payload, path=RESULTS / f'{name}.json')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
