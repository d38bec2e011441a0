"""The online estimate's trajectory against the batch posterior (PNG bytes; it only draws)."""

from __future__ import annotations

import numpy as np

from .figures import _plt, _png


def online_trajectory_figure(
    time_s: np.ndarray,
    mean: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    ready: np.ndarray,
    *,
    alarms_s: np.ndarray | None = None,
    batch: dict | None = None,
    truth: float | None = None,
    baseline: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    title: str = "",
) -> bytes:
    """C_x over driving time: the online mean and 90 % interval (faint until enough evidence).

    Parameters
    ----------
    time_s, mean, low, high : ndarray
        Per step: time [s], C_x mean and 90 % interval [-].
    ready : ndarray of bool
        Enough evidence at each step (the value is reported only there).
    alarms_s : ndarray, optional
        Times of change alarms [s].
    batch : dict, optional
        The batch posterior of the whole stream, ``{"mean", "sd", "hdi_90"}``.
    truth : float, optional
        True C_x (simulated or external drives).
    baseline : (time_s, mean, sd), optional
        A comparison filter's C_x (the linear-model EKF), drawn as a dashed line with ±1.645 sd.
    """
    plt = _plt()
    minutes = np.asarray(time_s) / 60.0
    ready = np.asarray(ready, dtype=bool)
    fig, ax = plt.subplots(figsize=(7.5, 3.8))
    ax.fill_between(minutes, low, high, color="#1f77b4", alpha=0.12, lw=0, label="not ready")
    shown = np.where(ready, 1.0, np.nan)
    ax.fill_between(minutes, low * shown, high * shown, color="#1f77b4", alpha=0.35, lw=0)
    ax.plot(minutes, mean, color="#1f77b4", lw=0.8, alpha=0.4)
    ax.plot(minutes, mean * shown, color="#1f77b4", lw=1.8, label="online, 90 % (ready)")
    if baseline is not None:
        t, m, s = (np.asarray(x) for x in baseline)
        ax.plot(t / 60.0, m, "--", color="#ff7f0e", lw=1.2, label="linear EKF")
        ax.fill_between(t / 60.0, m - 1.645 * s, m + 1.645 * s, color="#ff7f0e", alpha=0.12, lw=0)
    if batch is not None:
        lo, hi = batch["hdi_90"]
        ax.axhspan(lo, hi, color="0.5", alpha=0.2, lw=0)
        ax.axhline(batch["mean"], color="0.3", lw=1.2, label="batch posterior, 90 %")
    if truth is not None:
        ax.axhline(truth, color="#d62728", lw=1.2, ls=":", label="truth")
    for k, a in enumerate(np.asarray(alarms_s if alarms_s is not None else [])):
        ax.axvline(a / 60.0, color="#9467bd", lw=1.0, label="change alarm" if k == 0 else None)
    finite = np.isfinite(high) & ready
    if finite.any():
        lo_y = np.nanmin(low[finite])
        hi_y = np.nanmax(high[finite])
        pad = 0.5 * (hi_y - lo_y) + 1.0
        ax.set_ylim(lo_y - pad, hi_y + pad)
    ax.set_xlabel("driving time [min]")
    ax.set_ylabel("C_x [-]")
    ax.set_title(title or "C_x online against the batch posterior", fontsize=10)
    ax.legend(fontsize=7, loc="best")
    return _png(fig)


__all__ = ["online_trajectory_figure"]
