"""Summarise mf_lateral_sets.csv (car and SUV rows) into a prior over the lateral curve shape.

Reads the CSV next to this file and prints JSON; no network access. Statistics over the distinct
car/SUV lateral sets, measured or generic alike:
  C_minus_1: median and log-sd (sample sd of ln(C-1))
  E (= PEY1*LEY, the sign-symmetric part) and E_pos (E for alpha>0, with PEY3): mean and sd
  Ky_over_Fz (1/rad): median and log-sd
  ky_load_sens (d ln(Ky/Fz) / d(dFz/Fz0) at nominal load): median and sd
  ratio_30pct / ratio_50pct (secant/tangent slope at 30 % / 50 % of the peak): median, min, max
"""

from __future__ import annotations

import csv
import json
import math
import statistics as st
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main() -> None:
    with open(HERE / "mf_lateral_sets.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["class"] in ("car", "suv")]
    col = lambda k: [float(r[k]) for r in rows]  # noqa: E731
    c1 = [c - 1.0 for c in col("C")]
    ky = col("Ky_over_Fz")
    out = {
        "n_sets": len(rows),
        "n_by_class": {k: sum(r["class"] == k for r in rows) for k in ("car", "suv")},
        "n_by_measured": {
            k: sum(r["measured"] == k for r in rows) for k in sorted({r["measured"] for r in rows})
        },
        "C_minus_1": {
            "median": round(st.median(c1), 4),
            "log_sd": round(st.stdev([math.log(v) for v in c1]), 4),
        },
        "E": {"mean": round(st.mean(col("E")), 4), "sd": round(st.stdev(col("E")), 4)},
        "E_pos": {"mean": round(st.mean(col("E_pos")), 4), "sd": round(st.stdev(col("E_pos")), 4)},
        "Ky_over_Fz": {
            "median": round(st.median(ky), 3),
            "log_sd": round(st.stdev([math.log(v) for v in ky]), 4),
        },
        "ky_load_sens": {
            "median": round(st.median(col("ky_load_sens")), 4),
            "sd": round(st.stdev(col("ky_load_sens")), 4),
        },
    }
    for k in ("ratio_30pct", "ratio_50pct"):
        v = col(k)
        out[k] = {"median": round(st.median(v), 4), "min": min(v), "max": max(v)}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
