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
from ..inference.lateral.model import (
    DEFAULT_EFFECTS,
    LATERAL_EFFECTS,
    LateralPriors,
    log_likelihoods,
)
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
    in_default : bool
        Whether the default model carries it.
    elpd_gain : float
        ELPD(with the effect) − ELPD(without it), summed over samples.
    elpd_gain_se : float
        Its standard error, times √VIF of the steering equation's residuals.
    found : bool
        ``elpd_gain > GAIN_SE_FACTOR · elpd_gain_se``.
    with_effect, without : dict
        ``to_dict()`` of the fits with and without the effect.
    """

    effect: str
    in_default: bool
    elpd_gain: float
    elpd_gain_se: float
    found: bool
    with_effect: dict
    without: dict

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class LateralEffects:
    """The default model's fit and each effect's gain (:func:`criticize_lateral_effects`)."""

    full: dict
    gains: tuple[EffectGain, ...]

    def to_dict(self) -> dict:
        return {"full": self.full, "gains": [g.to_dict() for g in self.gains]}


def pointwise_log_likelihood(
    fit: LateralFit, obs: CorneringObservations, draws: int = LOO_DRAWS
) -> np.ndarray:
    """Log-likelihood of each sample (both equations) at ``draws`` posterior draws (draws × n),
    the draws with a non-finite value left out.

    Only samples in both equations' masks (:attr:`CorneringObservations.mask_kinematic`) count,
    so that models with different effects are compared on the same samples.
    """
    names = [str(v) for v in fit.fit.posterior.data_vars if v != "understeer_gradient"]
    total = fit.draws(names[0]).shape[0]
    idx = np.linspace(0, total - 1, min(draws, total)).astype(int)
    stacked = {n: jnp.asarray(fit.draws(n)[idx]) for n in names}
    keep = np.asarray(obs.mask_kinematic)

    def one(point):
        log_steer, log_kin = log_likelihoods(obs, point)
        return log_steer + log_kin

    log_lik = np.asarray(jax.jit(jax.vmap(one))(stacked))[:, keep]
    # A Laplace draw far in a tail can put a force beyond the curve's reach (a NaN slip): such
    # draws are left out of the comparison rather than making it NaN.
    return log_lik[np.all(np.isfinite(log_lik), axis=1)]


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
    """Each effect's ELPD gain: the default model against it without the effect (an effect of
    :data:`~tyrebayes.inference.lateral.model.DEFAULT_EFFECTS`), or with it added (one the
    default leaves out).

    Examples
    --------
    >>> result = criticize_lateral_effects(obs)  # doctest: +SKIP
    >>> [g.effect for g in result.gains if g.found]  # doctest: +SKIP
    """
    base_priors = LateralPriors()
    base = fit_lateral(obs, priors=base_priors, surface=surface, seed=seed)
    base_loo = _loo(base, obs)
    vif = json.loads(base.fit.data.attrs["lateral_vif"])[0]
    gains = []
    for effect in effects:
        included = effect in DEFAULT_EFFECTS
        other_priors = base_priors.without(effect) if included else base_priors.adding(effect)
        other = fit_lateral(obs, priors=other_priors, surface=surface, seed=seed)
        other_loo = _loo(other, obs)
        with_effect, without = (base_loo, other_loo) if included else (other_loo, base_loo)
        diff = np.asarray(with_effect.elpd_i) - np.asarray(without.elpd_i)
        gain = float(diff.sum())
        se = float(np.sqrt(diff.size * np.var(diff)) * np.sqrt(vif))
        gains.append(
            EffectGain(
                effect=effect,
                in_default=included,
                elpd_gain=gain,
                elpd_gain_se=se,
                found=bool(gain > GAIN_SE_FACTOR * se),
                with_effect=(base if included else other).to_dict(),
                without=(other if included else base).to_dict(),
            )
        )
    return LateralEffects(full=base.to_dict(), gains=tuple(gains))
