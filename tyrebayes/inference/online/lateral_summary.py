"""What the online lateral estimator reports: its estimate, readiness and trajectory.

:class:`OnlineLateral` is the estimate after a block, with the readiness rule of
:mod:`.lateral` (the batch fit's identification rule, in the Gaussian);
:meth:`OnlineLateral.to_dict` is the ``"lateral"`` object of ``tyrebayes online --json``.
:class:`LateralTrajectory` holds each
block's c_y moments (log space), from which the benchmarks read jumps and agreement over time.
"""

from __future__ import annotations

import math

import equinox as eqx
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from ..lateral.data import G
from ..summary import summarize

#: z of a central 90 % interval of a Normal.
Z90 = 1.6448536269514722
#: Draws of the Gaussian behind a reported summary (fixed seed: the same state, the same numbers).
SUMMARY_DRAWS = 4000


def prior_k_sd(log_c_mean: float, log_c_sd: float) -> float:
    """sd of K = (1/c_f − 1/c_r)/g under independent log-normal axle priors (exact).

    Examples
    --------
    >>> round(prior_k_sd(math.log(16.5), 0.5) * 1e3, 3)
    5.278
    """
    var_inverse = math.exp(-2.0 * log_c_mean) * (math.exp(2 * log_c_sd**2) - math.exp(log_c_sd**2))
    return math.sqrt(2.0 * var_inverse) / G


def k_moments(
    log_c_mean: Float[ArrayLike, "... 2"], log_c_cov: Float[ArrayLike, "... 2 2"]
) -> tuple[Float[np.ndarray, "..."], Float[np.ndarray, "..."]]:
    """Mean and sd of K = (e^(−x_f) − e^(−x_r))/g for x ~ N(mean, cov), to first order.

    Examples
    --------
    >>> m, s = k_moments(np.log([14.0, 18.0]), np.eye(2) * 1e-6)
    >>> round(float(m) * 1e3, 4)
    1.6186
    """
    # NumPy: called on the host, where eager JAX operations would each compile a program.
    log_c_mean, log_c_cov = np.asarray(log_c_mean), np.asarray(log_c_cov)
    inv = np.exp(-log_c_mean)
    mean = (inv[..., 0] - inv[..., 1]) / G
    grad = np.stack([-inv[..., 0], inv[..., 1]], axis=-1) / G
    var = np.einsum("...i,...ij,...j->...", grad, log_c_cov, grad)
    return np.asarray(mean), np.asarray(np.sqrt(np.maximum(var, 0.0)))


class LateralTrajectory(eqx.Module):
    """Each block's c_y moments.

    Attributes
    ----------
    time_s : Float[Array, " blocks"]
        Time at each block's end [s].
    log_c_y_mean : Float[Array, "blocks 2"]
        Mean of log c_y front, rear.
    log_c_y_cov : Float[Array, "blocks 2 2"]
        Their covariance.
    vif_settled : Bool[Array, " blocks"]
        Whether the VIFs had seen enough 30 s batches (:attr:`OnlineLateral.vif_settled`).
    """

    time_s: Float[Array, " blocks"]
    log_c_y_mean: Float[Array, "blocks 2"]
    log_c_y_cov: Float[Array, "blocks 2 2"]
    vif_settled: Bool[Array, " blocks"]

    def estimates(self) -> dict[str, dict[str, np.ndarray]]:
        """Per block: ``c_y_front``, ``c_y_rear`` and ``understeer_gradient`` as arrays of
        ``mean``, ``low``, ``high`` (90 %) and ``sd`` (log-normal c_y; K to first order).

        Examples
        --------
        >>> import jax.numpy as jnp
        >>> t = LateralTrajectory(jnp.ones(1), jnp.log(jnp.asarray([[14.0, 18.0]])),
        ...                       jnp.eye(2)[None] * 1e-4, jnp.ones(1, bool))
        >>> round(float(t.estimates()["c_y_front"]["low"][0]), 2)
        13.77
        """
        m = np.asarray(self.log_c_y_mean)
        sd = np.sqrt(np.maximum(np.diagonal(np.asarray(self.log_c_y_cov), axis1=-2, axis2=-1), 0))
        out = {}
        for j, name in enumerate(("c_y_front", "c_y_rear")):
            out[name] = {
                "mean": np.exp(m[:, j] + 0.5 * sd[:, j] ** 2),
                "sd": np.exp(m[:, j] + 0.5 * sd[:, j] ** 2) * np.sqrt(np.expm1(sd[:, j] ** 2)),
                "low": np.exp(m[:, j] - Z90 * sd[:, j]),
                "high": np.exp(m[:, j] + Z90 * sd[:, j]),
            }
        k, k_sd = (np.asarray(v) for v in k_moments(self.log_c_y_mean, self.log_c_y_cov))
        out["understeer_gradient"] = {
            "mean": k,
            "sd": k_sd,
            "low": k - Z90 * k_sd,
            "high": k + Z90 * k_sd,
        }
        return out


class OnlineLateral(eqx.Module):
    """The online lateral estimate after a block, and its readiness.

    Attributes
    ----------
    mean, cov : Array
        The Gaussian over the unconstrained coordinates (:func:`~.lateral_sites.linear_sites`).
    names : tuple of str
    time_s : Float[Array, ""]
        Time of the last block's end [s].
    prior_log_c_y_mean, prior_log_c_y_sd : Float[Array, ""]
        Each axle's prior on log c_y.
    contraction : float
        The readiness rule's share of the prior sd
        (:data:`~tyrebayes.inference.lateral.posterior_checks.K_CONTRACTION`).
    n_samples, n_skipped_longitudinal : Float[Array, ""]
        10 Hz samples read; samples left out for |a_x| (:mod:`.lateral_blocks`).
    steering_vif, kinematic_vif : Float[Array, ""]
        The equations' variance inflation in use.
    vif_settled : Bool[Array, ""]
        Whether both VIFs have seen enough 30 s batches to include the slow correlations
        (:mod:`.lateral`); nothing is reported before.
    converged : Bool[Array, ""]
        Whether the last block's mode was reached (its Gauss-Newton steps ended below their
        tolerance); nothing is reported from one that was not.
    """

    mean: Float[Array, " p"]
    cov: Float[Array, "p p"]
    names: tuple[str, ...] = eqx.field(static=True)
    time_s: Float[Array, ""]
    prior_log_c_y_mean: Float[Array, ""]
    prior_log_c_y_sd: Float[Array, ""]
    contraction: float = eqx.field(static=True)
    n_samples: Float[Array, ""]
    n_skipped_longitudinal: Float[Array, ""]
    steering_vif: Float[Array, ""]
    kinematic_vif: Float[Array, ""]
    vif_settled: Bool[Array, ""]
    converged: Bool[Array, ""]

    def _rows(self) -> list[int]:
        return [self.names.index("c_y_front"), self.names.index("c_y_rear")]

    @property
    def k_contracted(self) -> bool:
        """Whether K's sd is at most ``contraction`` of its prior's (the batch fit's
        identification rule, which is all a whole drive's fit needs)."""
        rows = self._rows()
        _, k_sd = k_moments(np.asarray(self.mean)[rows], np.asarray(self.cov)[np.ix_(rows, rows)])
        limit = self.contraction * prior_k_sd(
            float(self.prior_log_c_y_mean), float(self.prior_log_c_y_sd)
        )
        return bool(float(k_sd) <= limit)

    @property
    def k_identified(self) -> bool:
        """Whether the mode was reached, the VIFs are settled and K is contracted
        (:attr:`k_contracted`): what a car reports K on."""
        return bool(self.vif_settled) and bool(self.converged) and self.k_contracted

    @property
    def axle_log_sds(self) -> tuple[float, float]:
        """Posterior sd of log c_y front, rear."""
        rows = self._rows()
        cov = np.asarray(self.cov)
        return tuple(float(np.sqrt(cov[i, i])) for i in rows)

    @property
    def split_identified(self) -> bool:
        """Whether front and rear are told apart: K identified and each axle's log-sd at most
        ``contraction`` of its prior's."""
        limit = self.contraction * float(self.prior_log_c_y_sd)
        return self.k_identified and all(sd <= limit for sd in self.axle_log_sds)

    def _draws(self, seed: int) -> dict[str, np.ndarray]:
        rng = np.random.default_rng(seed)
        cov = np.asarray(self.cov)
        root = np.linalg.cholesky(0.5 * (cov + cov.T) + 1e-300 * np.eye(cov.shape[0]))
        flat = (
            np.asarray(self.mean)[None, :] + rng.normal(size=(SUMMARY_DRAWS, cov.shape[0])) @ root.T
        )
        out = {
            n: flat[:, i] if n in ("steering_offset", "ay_offset") else np.exp(flat[:, i])
            for i, n in enumerate(self.names)
        }
        out["understeer_gradient"] = (1.0 / out["c_y_front"] - 1.0 / out["c_y_rear"]) / G
        return out

    def reason(self) -> str:
        """Why a value is withheld ("" when all are reported)."""
        if not bool(self.converged):
            return (
                "lateral: not converged: the last block's Gauss-Newton steps reached their "
                "limit before the mode"
            )
        if not bool(self.vif_settled):
            return (
                "lateral: not yet: the residuals' slow correlation (30 s batches) is not "
                "measured yet, so the intervals are not yet trusted"
            )
        if not self.k_identified:
            return (
                "lateral: not yet: the cornering so far has not narrowed the understeer "
                f"gradient to {self.contraction:g} of its prior's spread"
            )
        if not self.split_identified:
            sd_f, sd_r = self.axle_log_sds
            return (
                "lateral: not yet: the data cannot tell front from rear yet (log c_y sd "
                f"front {sd_f:.2f}, rear {sd_r:.2f}; reported at ≤ "
                f"{self.contraction * float(self.prior_log_c_y_sd):.2f}); understeer gradient only"
            )
        return ""

    def to_dict(self, seed: int = 0) -> dict:
        """The ``"lateral"`` object of ``tyrebayes online --json``.

        ``c_y_front``, ``c_y_rear`` and ``understeer_gradient`` as ``{"mean", "sd", "hdi_90"}``,
        each null while not yet identified (``reason`` says why); the readiness flags, the
        front/rear correlation, the steering ratio, the samples read and skipped, the VIFs.

        Examples
        --------
        >>> from tyrebayes.inference.online.lateral import OnlineLateralEstimator
        >>> est = OnlineLateralEstimator.create()
        >>> d = est.result(est.init()).to_dict()
        >>> d["understeer_gradient"], d["reason"][:21]
        (None, 'lateral: not yet: the')
        """
        draws = self._draws(seed)
        k_ready, split_ready = self.k_identified, self.split_identified
        rows = self._rows()
        cov = np.asarray(self.cov)
        corr = cov[rows[0], rows[1]] / math.sqrt(cov[rows[0], rows[0]] * cov[rows[1], rows[1]])
        return {
            "c_y_front": summarize(draws["c_y_front"]).to_dict() if split_ready else None,
            "c_y_rear": summarize(draws["c_y_rear"]).to_dict() if split_ready else None,
            "understeer_gradient": summarize(draws["understeer_gradient"]).to_dict()
            if k_ready
            else None,
            "ready": bool(split_ready),
            "understeer_gradient_ready": bool(k_ready),
            "reason": self.reason(),
            "front_rear_correlation": float(corr),
            "steering_ratio": summarize(draws["steering_ratio"]).to_dict(),
            "time_s": float(self.time_s),
            "samples": int(self.n_samples),
            "samples_skipped_longitudinal": int(self.n_skipped_longitudinal),
            "steering_vif": float(self.steering_vif),
            "kinematic_vif": float(self.kinematic_vif),
            "converged": bool(self.converged),
            "method": "online moments",
        }

    def unconditional(self, seed: int = 0) -> dict:
        """``c_y_front``, ``c_y_rear``, ``understeer_gradient`` summaries whether or not ready
        (for benchmarks that compare every drive)."""
        draws = self._draws(seed)
        return {
            k: summarize(draws[k]).to_dict()
            for k in ("c_y_front", "c_y_rear", "understeer_gradient")
        }


__all__ = ["LateralTrajectory", "OnlineLateral", "k_moments", "prior_k_sd"]
