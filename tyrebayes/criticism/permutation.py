"""Calibrated scan p-values: Freedman-Lane permutations of the baseline's residuals, vectorised.

For a Gaussian linear baseline y = X0 b + e and a candidate's columns Xj the scan statistic is the
share of the baseline's residual sum of squares the candidate explains,

    T_j(y) = ||Qj' M0 y||^2 / ||M0 y||^2,

(a monotone function of the partial F statistic; M0 = I - H0 projects out the baseline, Qj is an
orthonormal basis of M0 Xj). Its null distribution is built by permuting the baseline's residuals
r0 = M0 y (Freedman & Lane 1983): y* = H0 y + P r0 keeps the baseline's fitted part and breaks any
link between the misfit and the candidate. The p-value (1 + #{T(y*) >= T(y)}) / (B + 1) is
calibrated without assuming Gaussian noise, and one set of permutations serves every candidate
(their dependence is kept, as the false-discovery-rate procedure over them may use).

Permutations are drawn within strata (tyre types: the fleet model gives each type its own noise
scale, so only rows of one type are exchangeable). Because Qj lies in the range of M0,
Qj' M0 P r0 = Qj' P r0 and ||M0 P r0||^2 = ||r0||^2 - ||Q0' P r0||^2: every permutation costs two
small matrix products, all B of them in one call.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import Float, Int

#: Permutations per scan: the smallest p-value is 1 / (B + 1) = 0.001.
DEFAULT_PERMUTATIONS = 999


def stratified_permutations(
    strata: Int[np.ndarray, " n"], n_permutations: int, rng: np.random.Generator
) -> Int[np.ndarray, "b n"]:
    """Row indices of ``n_permutations`` permutations that only exchange rows of one stratum.

    Examples
    --------
    >>> idx = stratified_permutations(np.array([0, 0, 1, 1, 1]), 4, np.random.default_rng(0))
    >>> idx.shape, bool(np.all(np.sort(idx[:, 2:], axis=1) == [2, 3, 4]))
    ((4, 5), True)
    """
    n = strata.shape[0]
    out = np.tile(np.arange(n), (n_permutations, 1))
    for s in np.unique(strata):
        rows = np.flatnonzero(strata == s)
        # argsort of uniforms: an independent uniform permutation per row, all at once.
        order = np.argsort(rng.random((n_permutations, rows.shape[0])), axis=1)
        out[:, rows] = rows[order]
    return out


def _orthonormal(
    x: Float[np.ndarray, "n k"], scale: float | None = None
) -> Float[np.ndarray, "n r"]:
    """Orthonormal basis of the column space (rank-revealing: dependent columns dropped).

    ``scale``: the norm the columns had before a projection; directions that the projection
    reduced to rounding error relative to it carry no rank.
    """
    if x.shape[1] == 0:
        return x
    u, s, _ = np.linalg.svd(x, full_matrices=False)
    ref = s.max() if scale is None else max(scale, s.max())
    keep = s > ref * 1e-10
    return u[:, keep]


def permutation_pvalues(
    y: Float[np.ndarray, " n"],
    x0: Float[np.ndarray, "n p"],
    extras: list[Float[np.ndarray, "n _q"]],  # each candidate its own width
    permutations: Int[np.ndarray, "b n"],
) -> list[tuple[float, float]]:
    """Freedman-Lane permutation p-values of adding each of ``extras`` to the baseline ``x0``.

    Parameters
    ----------
    y : ndarray (n,)
        Outcome.
    x0 : ndarray (n, p)
        Baseline design.
    extras : list of ndarray (n, q)
        Each candidate's columns (finite), all on the same rows.
    permutations : ndarray (B, n)
        Row indices of the permutations (:func:`stratified_permutations`), shared by all.

    Returns
    -------
    list of (p_value, explained)
        Per candidate: (1 + #{T(y*) >= T(y)}) / (B + 1), 1 when the candidate adds no rank; and
        T(y), the share of the baseline's residual sum of squares the candidate explains.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> x = rng.normal(size=40)
    >>> y = 0.6 * x + rng.normal(size=40)
    >>> perms = stratified_permutations(np.zeros(40, int), 999, rng)
    >>> [(p, share)] = permutation_pvalues(y, np.ones((40, 1)), [x[:, None]], perms)
    >>> bool(p < 0.01)
    True
    """
    q0 = _orthonormal(x0)
    r0 = y - q0 @ (q0.T @ y)
    total = float(r0 @ r0)
    pr = r0[permutations]  # (B, n): every permuted residual vector at once
    den = np.maximum(total - np.sum((pr @ q0) ** 2, axis=1), 1e-300)
    out = []
    for extra in extras:
        xj = extra - q0 @ (q0.T @ extra)
        qj = _orthonormal(xj, scale=float(np.linalg.norm(extra, 2)))
        if qj.shape[1] == 0 or total <= 0.0:
            out.append((1.0, 0.0))
            continue
        t_obs = float(np.sum((qj.T @ r0) ** 2)) / total
        t_perm = np.sum((pr @ qj) ** 2, axis=1) / den
        # A tolerance so that ties in floating point count as ties (discrete candidates).
        exceed = int(np.sum(t_perm >= t_obs * (1.0 - 1e-10)))
        out.append(((1.0 + exceed) / (1.0 + permutations.shape[0]), t_obs))
    return out


def permutation_pvalue(
    y: Float[np.ndarray, " n"],
    x0: Float[np.ndarray, "n p"],
    extra: Float[np.ndarray, "n q"],
    permutations: Int[np.ndarray, "b n"],
) -> tuple[float, float]:
    """:func:`permutation_pvalues` of one candidate: ``(p_value, explained)``."""
    return permutation_pvalues(y, x0, [extra], permutations)[0]


def unit_means(
    values: Float[np.ndarray, "n k"], units: Int[np.ndarray, " n"]
) -> Float[np.ndarray, "u k"]:
    """Column means per unit (units labelled 0 .. U-1)."""
    counts = np.bincount(units).astype(float)
    return np.column_stack(
        [np.bincount(units, weights=values[:, j]) / counts for j in range(values.shape[1])]
    )
