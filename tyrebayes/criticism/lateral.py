"""What each nuisance effect of the lateral model buys: ELPD with and without it.

The package's own simulator (and the lateral model's first version) assumed what a textbook
single-track model does: the accelerometer reads the tyres' force, the steering sensor has no
offset, the tyres answer at once, the vehicle file's yaw inertia is right. Real cars and the
external drives break each of these. :func:`criticize_lateral_effects` fits the drive with the
full model and with each effect left out in turn (:meth:`LateralPriors.without`), and compares
them by PSIS-LOO on the pointwise log-likelihood of both equations at the Laplace draws.

The samples' errors are correlated in time, so LOO over samples reads the gain as more certain
than it is; the SE is given multiplied by the square root of the steering equation's variance
inflation factor (how many samples count as one), and a gain counts only where it exceeds
:data:`GAIN_SE_FACTOR` of those SEs.
"""

from __future__ import annotations

import dataclasses
import json

import jax
import jax.numpy as jnp
import numpy as np
import xarray as xr

from ..inference.diagnostics import loo
from ..inference.lateral.data import CorneringObservations
from ..inference.lateral.fit import fit_lateral
from ..inference.lateral.model import LATERAL_EFFECTS, LateralPriors, residuals
from ..inference.lateral.result import LateralFit

#: Posterior draws the pointwise log-likelihood is computed at.
LOO_DRAWS = 200
#: An effect is found where its ELPD gain exceeds this many (VIF-inflated) standard errors.
GAIN_SE_FACTOR = 2.0


@dataclasses.dataclass(frozen=True)
class EffectGain:
    """One effect: the ELPD the full model gains over the model without it, and its estimates.

    Attributes
    ----------
    effect : str
        One of :data:`~tyrebayes.inference.lateral.model.LATERAL_EFFECTS`.
    elpd_gain : float
        ELPD(full) − ELPD(without the effect), summed over samples.
    elpd_gain_se : float
        Its standard error, times √VIF of the steering equation's residuals.
    found : bool
        ``elpd_gain > GAIN_SE_FACTOR · elpd_gain_se``.
    without : dict
        The model without the effect: ``to_dict()`` of its fit.
    """

    effect: str
    elpd_gain: float
    elpd_gain_se: float
    found: bool
    without: dict

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class LateralEffects:
    """The full model's fit and each effect's gain (:func:`criticize_lateral_effects`)."""

    full: dict
    gains: tuple[EffectGain, ...]

    def to_dict(self) -> dict:
        return {"full": self.full, "gains": [g.to_dict() for g in self.gains]}


def pointwise_log_likelihood(
    fit: LateralFit, obs: CorneringObservations, draws: int = LOO_DRAWS
) -> np.ndarray:
    """Log-likelihood of each sample (both equations) at ``draws`` posterior draws (draws × n).

    Only samples in both equations' masks (:attr:`CorneringObservations.mask_kinematic`) count,
    so that models with different effects are compared on the same samples.
    """
    names = [str(v) for v in fit.fit.posterior.data_vars if v != "understeer_gradient"]
    total = fit.draws(names[0]).shape[0]
    idx = np.linspace(0, total - 1, min(draws, total)).astype(int)
    stacked = {n: jnp.asarray(fit.draws(n)[idx]) for n in names}
    keep = np.asarray(obs.mask_kinematic)

    def one(point):
        steer, kin = residuals(obs, point)
        return jax.scipy.stats.norm.logpdf(
            steer, 0.0, point["steer_noise"]
        ) + jax.scipy.stats.norm.logpdf(kin, 0.0, point["kinematic_noise"])

    return np.asarray(jax.jit(jax.vmap(one))(stacked))[:, keep]


def _loo(fit: LateralFit, obs: CorneringObservations):
    log_lik = pointwise_log_likelihood(fit, obs)
    tree = xr.DataTree.from_dict(
        {
            "posterior": xr.Dataset({"x": (("chain", "draw"), np.zeros((1, log_lik.shape[0])))}),
            "log_likelihood": xr.Dataset({"y": (("chain", "draw", "sample"), log_lik[None])}),
        }
    )
    return loo(tree, "y", reff=1.0)


def criticize_lateral_effects(
    obs: CorneringObservations,
    *,
    surface: str = "dry",
    seed: int = 0,
    effects: tuple[str, ...] = LATERAL_EFFECTS,
) -> LateralEffects:
    """Fit with every effect, and without each of ``effects`` in turn; their ELPD gains.

    Examples
    --------
    >>> result = criticize_lateral_effects(obs)  # doctest: +SKIP
    >>> [g.effect for g in result.gains if g.found]  # doctest: +SKIP
    """
    full = fit_lateral(obs, surface=surface, seed=seed)
    full_loo = _loo(full, obs)
    vif = json.loads(full.fit.data.attrs["lateral_vif"])[0]
    gains = []
    for effect in effects:
        reduced = fit_lateral(
            obs, priors=LateralPriors().without(effect), surface=surface, seed=seed
        )
        reduced_loo = _loo(reduced, obs)
        diff = np.asarray(full_loo.elpd_i) - np.asarray(reduced_loo.elpd_i)
        gain = float(diff.sum())
        se = float(np.sqrt(diff.size * np.var(diff)) * np.sqrt(vif))
        gains.append(
            EffectGain(
                effect=effect,
                elpd_gain=gain,
                elpd_gain_se=se,
                found=bool(gain > GAIN_SE_FACTOR * se),
                without=reduced.to_dict(),
            )
        )
    return LateralEffects(full=full.to_dict(), gains=tuple(gains))
