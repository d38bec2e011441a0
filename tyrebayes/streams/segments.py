"""Label every sample with a driving regime and summarise the labelled segments.

Regimes decide what a sample can teach: free rolling pins the per-wheel radius offsets, traction
and braking the slip stiffness, high-slip (ABS, wheel spin) events the friction peak, and
cornering contaminates the longitudinal slip with lateral slip and load transfer.

Examples
--------
>>> import numpy as np
>>> label = np.array([1, 1, 2, 2, 2, 0])
>>> summarize_segments(np.arange(6) * 0.5, label, min_segment_s=1.0)["traction"]
{'count': 1, 'seconds': 1.5}
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from jaxtyping import Bool, Float, Int

from .order_stats import median

SEGMENT_REGIMES: tuple[str, ...] = (
    "invalid",
    "free_rolling",
    "traction",
    "braking",
    "high_slip",
    "cornering",
)
"""Label names; a sample's label is the index into this tuple."""

INVALID, FREE_ROLLING, TRACTION, BRAKING, HIGH_SLIP, CORNERING = range(len(SEGMENT_REGIMES))


@dataclass(frozen=True)
class SegmentThresholds:
    """Thresholds that separate the regimes (dimensionless ρ and σ, SI otherwise).

    Parameters
    ----------
    rho_free : float
        |ρ_x| of the driven axle below this is free rolling (no drive or brake torque); 0.02 is
        about 0.2 m/s² of acceleration, the resolution of a levelled IMU after offset removal.
    slip_high : float
        |σ_x| of any wheel above this is a high-slip (ABS or spin) event; passenger tyres peak
        at 0.08-0.15 slip on dry asphalt and much lower on snow and ice.
    lateral_mps2 : float
        |a_y| above this is cornering; 1.5 m/s² is a brisk bend, where lateral slip starts to
        matter for the longitudinal force balance.
    min_speed_mps : float
        Below this V_x slip is ill-conditioned (division by V_x) and samples are invalid.
    """

    rho_free: float = 0.02
    slip_high: float = 0.08
    lateral_mps2: float = 1.5
    min_speed_mps: float = 3.0

    def __post_init__(self):
        for name in ("rho_free", "slip_high", "lateral_mps2", "min_speed_mps"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"SegmentThresholds.{name}: expected a value > 0, got {value!r}")


DEFAULT_THRESHOLDS = SegmentThresholds()


def label_samples(
    valid: Bool[np.ndarray, "n"],
    rho_driven: Float[np.ndarray, "n"],
    max_abs_slip: Float[np.ndarray, "n"],
    spin: Bool[np.ndarray, "n"],
    lateral_mps2: Float[np.ndarray, "n"],
    thresholds: SegmentThresholds = DEFAULT_THRESHOLDS,
) -> Int[np.ndarray, "n"]:
    """One label per sample, by priority invalid > high_slip > cornering > braking/traction/free.

    Parameters
    ----------
    valid : ndarray of bool
        Samples with a usable V_x (moving, no gap).
    rho_driven : ndarray
        ρ_x of the driven axle [-].
    max_abs_slip : ndarray
        Largest |σ_x| over the four wheels [-].
    spin : ndarray of bool
        The thesis' spin check (chapter 4.3.2) fired.
    lateral_mps2 : ndarray
        Lateral acceleration [m/s²], e.g. V_x · yaw rate.

    Returns
    -------
    ndarray of int
        Index into :data:`SEGMENT_REGIMES`.
    """
    # Later assignments take priority; each is one masked write into the same array.
    label = np.full(valid.shape, FREE_ROLLING, dtype=np.int64)
    label[rho_driven >= thresholds.rho_free] = TRACTION
    label[rho_driven <= -thresholds.rho_free] = BRAKING
    label[np.abs(lateral_mps2) > thresholds.lateral_mps2] = CORNERING
    # NaN slip compares False, as the 0 it counts for would; an infinite one stays high.
    label[spin | (max_abs_slip > thresholds.slip_high)] = HIGH_SLIP
    label[~(valid & np.isfinite(rho_driven) & np.isfinite(max_abs_slip))] = INVALID
    return label


def summarize_segments(
    time_s: Float[np.ndarray, "n"],
    label: Int[np.ndarray, "n"],
    min_segment_s: float = 0.5,
) -> dict[str, dict[str, float | int]]:
    """Count and total duration per regime.

    Parameters
    ----------
    time_s : ndarray
        Uniform time base [s].
    label : ndarray of int
        From :func:`label_samples`.
    min_segment_s : float
        A contiguous run counts as a segment if it lasts at least this long [s].

    Returns
    -------
    dict
        ``{regime: {"count": runs >= min_segment_s, "seconds": total time with that label}}``.
    """
    # np.median's, by one selection (order_stats).
    dt = median(np.diff(time_s), overwrite_input=True) if time_s.size > 1 else 0.0
    change = np.flatnonzero(np.diff(label) != 0) + 1
    starts = np.concatenate(([0], change))
    ends = np.concatenate((change, [label.size]))
    run_label = label[starts]
    run_seconds = (ends - starts) * dt
    out: dict[str, dict[str, float | int]] = {}
    for code, regime in enumerate(SEGMENT_REGIMES):
        mine = run_label == code
        out[regime] = {
            "count": int(np.sum(run_seconds[mine] >= min_segment_s)),
            "seconds": float(np.sum(run_seconds[mine])),
        }
    return out
