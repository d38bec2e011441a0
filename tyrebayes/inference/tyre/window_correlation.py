"""How much independent information a drive's windows hold: the slip-error variance inflation.

The per-tyre model treats the windows' slip errors as independent. They are not: the features
are smoothed over 0.2 s, which spills into the next 0.25 s window, and wheel-speed errors vary
slowly (on one simulated one-hour drive the standardised errors of adjacent windows correlated by
0.38, at 1 s by 0.18; sums over 10-300 s blocks had 2.2-2.4 times the variance of independent
errors). Counted as independent, a drive's thousands of windows claimed about √2.3 times the
precision they hold, and C_x's intervals were too narrow (50/90 % coverage 0.32-0.48/0.80-0.86).

The correction is a composite-likelihood magnitude adjustment (Ribatet, Cooley & Davison 2012,
Statistica Sinica 22): each drive's slip log-likelihood is multiplied by 1/VIF, with VIF the
variance inflation of its standardised residuals at the first fit's posterior mean, estimated
by batch means over blocks of :data:`BLOCK_WINDOWS` consecutive windows. A first-order
autoregressive error model was tried first and rejected: its likelihood regresses quasi-differenced
slips on quasi-differenced forces, whose noise the force-noise correction (made for levels) does
not remove; C_x came out 4-6 % high on two one-hour drives.

Examples
--------
>>> import numpy as np
>>> z = np.repeat(np.random.default_rng(0).standard_normal(4000), 2)  # pairs: VIF ≈ 2
>>> round(float(variance_inflation(z)), 1)
2.0
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Float

#: Windows per batch-means block: 10 s of 0.25 s windows, longer than the correlations seen.
BLOCK_WINDOWS = 40
#: Blocks needed for an estimate (its relative sd is about √(2/blocks): 0.45 at 10).
MIN_BLOCKS = 10
#: Largest inflation accepted: beyond it the residuals are not noise but a misfit to examine.
MAX_INFLATION = 10.0


def variance_inflation(z: Float[np.ndarray, "n"], block: int = BLOCK_WINDOWS) -> float:
    """Batch-means variance inflation of a sequence: var(block sums) / (block · var(z)).

    1 for independent values; (1 + φ)/(1 − φ) for an AR(1) sequence with lag-1 correlation φ.
    Clipped to [1, :data:`MAX_INFLATION`]; 1 when there are fewer than :data:`MIN_BLOCKS` blocks.
    """
    z = np.asarray(z, dtype=float)
    z = z[np.isfinite(z)]
    n_blocks = z.size // block
    if n_blocks < MIN_BLOCKS:
        return 1.0
    z = z - z.mean()
    variance = float(np.mean(z**2))
    if not variance > 0:
        return 1.0
    sums = z[: n_blocks * block].reshape(n_blocks, block).sum(axis=1)
    return float(np.clip(np.mean(sums**2) / (block * variance), 1.0, MAX_INFLATION))


def slip_weights(
    standardised_residual: Float[np.ndarray, "n"],
    slip_window: np.ndarray,
    drive_index: np.ndarray,
    n_drives: int,
) -> tuple[Float[np.ndarray, "n"], Float[np.ndarray, "d"]]:
    """Per-window slip weights 1/VIF of the window's drive, and each drive's VIF.

    Parameters
    ----------
    standardised_residual : ndarray, shape (n,)
        (σ_obs − loc)/scale of every window at a posterior point estimate.
    slip_window : ndarray of bool, shape (n,)
        Windows whose slip enters the likelihood (in time order within each drive).
    drive_index : ndarray of int, shape (n,)
    n_drives : int
    """
    inflation = np.ones(n_drives)
    for d in range(n_drives):
        inflation[d] = variance_inflation(standardised_residual[slip_window & (drive_index == d)])
    weights = np.where(slip_window, 1.0 / inflation[drive_index], 1.0)
    return weights, inflation


__all__ = ["BLOCK_WINDOWS", "slip_weights", "variance_inflation"]
