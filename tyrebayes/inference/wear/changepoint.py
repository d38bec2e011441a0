"""Tyre rotations and replacements in a drive history: steps in the front/rear radius ratio.

Between changes the ratio y_k (front over rear rolling radius, in mm of radius) drifts with the
difference of the axles' wear, which the drives' friction work predicts up to one factor:
Δy_k = y_{k+1} − y_k ≈ b x_k + noise, x_k = the interval's work difference front − rear. A change
swaps or renews the tyres and moves y by about the accumulated wear difference: a step.

Test: b is estimated robustly (median of Δy / x), the residuals e_k = Δy_k − b x_k are scaled by
a robust noise level s (1.4826 MAD), and a step between drives k − 1 and k is declared where
min(|e_{k−1}| / s, |e_{k−2} + e_{k−1}| / (√2 s), |e_{k−1} + e_k| / (√2 s)) exceeds z, with
P(|N(0,1)| > z) = false_alarm / (n − 1) (per channel: the ratio, and the speed scale where
logged, share the rate): a Bonferroni bound, so that a history of n drives without a change
raises a false alarm with probability at most ``false_alarm`` under Gaussian noise (checked by a
test).
The sums keep a single bad drive (two residuals of opposite sign) from reading as a step.
Declared steps closer than ``window`` drives keep the strongest.

Classification: a rotation moves y by about twice the accumulated drift of the segment before it
(the worn pair changes axle), a replacement by about once (both pairs new); the speed scale
against GNSS, where logged, adds the free-rolling axle's radius change (rotation: the worn
tyres arrive there; replacement: about none). The more likely of the two under the tyres'
manufacturing radius spread (``radius_spread_mm``) is reported with its probability.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np
from scipy.stats import norm

#: Family-wise false-alarm rate of :func:`detect_tyre_changes` in a history without a change.
FALSE_ALARM_RATE = 0.01
#: Fewest drives between two declared steps; and the window of the speed-scale comparison.
STEP_WINDOW = 3
#: Spread of a new tyre's rolling radius between tyres of one model [mm] (0.1 % of 316 mm):
#: the noise of a step's size for the rotation/replacement classification (assumption).
RADIUS_SPREAD_MM = 0.3


class TyreChanges(eqx.Module):
    """Detected tyre changes of a history.

    Attributes
    ----------
    index : ndarray of int
        Drive index at which each new tyre set (segment) starts (ascending).
    change_type : tuple of str
        ``"rotation"`` or ``"replacement"`` per change.
    probability : ndarray
        Probability of the reported change type against the other (equal prior odds).
    statistic : ndarray
        The test statistic at each change (in units of its noise sd).
    threshold : float
        The statistic's threshold z.
    false_alarm_rate : float
    """

    index: np.ndarray
    change_type: tuple[str, ...] = eqx.field(static=True)
    probability: np.ndarray
    statistic: np.ndarray
    threshold: float
    false_alarm_rate: float

    def segments(self, n_drives: int) -> np.ndarray:
        """Segment number of every drive, shape (n_drives,)."""
        seg = np.zeros(n_drives, dtype=int)
        for i in self.index:
            seg[int(i) :] += 1
        return seg


def step_threshold(n_drives: int, false_alarm: float = FALSE_ALARM_RATE) -> float:
    """z with P(|N(0,1)| > z) = false_alarm / (n_drives − 1) (two-sided Bonferroni)."""
    if not 0 < false_alarm < 1:
        raise ValueError(f"false_alarm: expected a value in (0, 1), got {false_alarm}")
    tests = max(n_drives - 1, 1)
    return float(norm.isf(false_alarm / tests / 2))


def _residuals(dy: np.ndarray, xs: np.ndarray) -> tuple[np.ndarray, float]:
    """Differences minus the robust work trend, and their robust scale (1.4826 MAD)."""
    use = (np.abs(xs) > 0) & np.isfinite(dy)
    slope = float(np.median(dy[use] / xs[use])) if use.sum() >= 3 else 0.0
    resid = dy - slope * xs
    finite = resid[np.isfinite(resid)]
    mad = float(np.median(np.abs(finite - np.median(finite)))) if finite.size else 0.0
    return resid, max(1.4826 * mad, 1e-6)


def detect_tyre_changes(
    ratio_mm: np.ndarray,
    work_difference_j: np.ndarray,
    speed_scale_mm: np.ndarray | None = None,
    *,
    false_alarm: float = FALSE_ALARM_RATE,
    window: int = STEP_WINDOW,
    radius_spread_mm: float = RADIUS_SPREAD_MM,
) -> TyreChanges:
    """Steps in the radius ratio of a drive history (module docstring).

    Parameters
    ----------
    ratio_mm : ndarray, shape (n,)
        Front/rear radius ratio of each drive as (ratio − 1) R_0 [mm], in drive order.
    work_difference_j : ndarray, shape (n,)
        The interval after each drive: friction-work difference front − rear [J] (scaled to the
        distance the drive stands for).
    speed_scale_mm : ndarray, shape (n,), optional
        Radius change of the free-rolling (V_x) axle against GNSS, −(scale − 1) R_0 [mm], signed
        so that the worn pair arriving there reads negative; NaN where not logged.
    false_alarm : float
        Family-wise false-alarm rate of the whole history.
    window : int
        Fewest drives between two steps; drives averaged on each side for the speed scale.
    radius_spread_mm : float
        Manufacturing spread of a tyre's radius [mm] (classification noise).

    Returns
    -------
    TyreChanges

    Examples
    --------
    >>> y = np.r_[np.zeros(10), np.full(10, 2.0)] + 0.01 * np.sin(np.arange(20.0))
    >>> detect_tyre_changes(y, np.zeros(20)).index.tolist()
    [10]
    """
    y = np.asarray(ratio_mm, dtype=float)
    x = np.asarray(work_difference_j, dtype=float)
    n = y.size
    threshold = step_threshold(n, false_alarm)
    empty = TyreChanges(
        np.zeros(0, dtype=int), (), np.zeros(0), np.zeros(0), threshold, false_alarm
    )
    if n < 2 * window + 1:
        return empty
    channels = [(np.diff(y), x[:-1])]
    ss = None if speed_scale_mm is None else np.asarray(speed_scale_mm, dtype=float)
    if ss is not None and np.isfinite(ss).sum() >= 2 * window + 1:
        channels.append((np.diff(ss), np.zeros(n - 1)))
    threshold = step_threshold(n, false_alarm / len(channels))
    stats = np.zeros(n)
    resid_y, scale_y = None, 1.0
    for dy, xs in channels:
        resid, scale = _residuals(dy, xs)
        if resid_y is None:
            resid_y, scale_y = resid, scale
        # step between drives k-1 and k: one large residual that neither neighbour undoes
        # (a single bad drive gives two of opposite sign)
        nxt = np.append(resid[1:], 0.0)
        prev = np.insert(resid[:-1], 0, 0.0)
        pair = np.minimum(np.abs(resid + nxt), np.abs(resid + prev)) / (np.sqrt(2.0) * scale)
        stat = np.minimum(np.abs(resid) / scale, pair)
        stats[1:] = np.maximum(stats[1:], np.nan_to_num(stat))
    candidates = [k for k in np.argsort(-np.abs(stats)) if abs(stats[k]) > threshold]
    chosen: list[int] = []
    for k in candidates:
        if all(abs(k - c) >= window for c in chosen):
            chosen.append(int(k))
    chosen.sort()
    if not chosen:
        return empty
    change_types, probs = [], []
    bounds = [0, *chosen]
    for i, k in enumerate(chosen):
        start = bounds[i]
        drift = float(y[k - 1] - y[start])
        step = float(resid_y[k - 1])
        sd = np.hypot(radius_spread_mm * 2.0, scale_y)
        # y moves by −2 drift at a rotation, −drift at a replacement
        log_rot = norm.logpdf(step, -2.0 * drift, sd)
        log_rep = norm.logpdf(step, -drift, sd)
        if ss is not None:
            b, a = ss[max(k - window, 0) : k], ss[k : k + window]
            if np.isfinite(b).any() and np.isfinite(a).any():
                ds = float(np.nanmean(a) - np.nanmean(b))
                sd_s = radius_spread_mm * np.sqrt(2.0)
                # the free-rolling axle receives the worn pair (rotation) or a new one
                log_rot += norm.logpdf(ds, -abs(drift), sd_s)
                log_rep += norm.logpdf(ds, 0.0, sd_s)
        p_rot = float(1.0 / (1.0 + np.exp(np.clip(log_rep - log_rot, -50, 50))))
        change_types.append("rotation" if p_rot >= 0.5 else "replacement")
        probs.append(max(p_rot, 1.0 - p_rot))
    return TyreChanges(
        np.asarray(chosen, dtype=int),
        tuple(change_types),
        np.asarray(probs),
        stats[chosen],
        threshold,
        false_alarm,
    )
