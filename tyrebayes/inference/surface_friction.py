"""The prior of the friction peak on each road surface, shared by the longitudinal and lateral fits.

Medians: dry asphalt ~1.0, wet ~0.75, packed snow ~0.35, ice ~0.12 (ranges of the measured braking
data in ``tyrebayes/data/braking_by_tyre_type.csv``, which give lower bounds 0.8-1.1 dry, 0.6-0.8
wet, 0.3-0.45 snow, 0.1-0.15 ice from mean deceleration). Log-scale sds: the same data give dry
0.9-1.1 for every tyre type (±15 %), wet 0.7-1.0, snow 0.18-0.45 and ice 0.08-0.15 (type matters
most on winter surfaces). A wide dry prior lets a drive without ABS read slip-signal distortions
at high force as a low peak (μ ~0.3 on dry asphalt, seen in simulation) and bias C_x through the
curve's shape.
"""

from __future__ import annotations

#: Prior median of the friction peak per surface [-].
MU_MEDIAN = {"dry": 1.0, "wet": 0.75, "snow": 0.35, "ice": 0.12}
#: Log-scale prior sd of the friction peak per surface [-].
MU_LOG_SD = {"dry": 0.15, "wet": 0.2, "snow": 0.35, "ice": 0.4}
