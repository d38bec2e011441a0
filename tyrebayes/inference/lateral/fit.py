"""Fitting the lateral model: MAP + Laplace (``"laplace"``) or NUTS (``"nuts"``), one result type.

The Laplace path minimises the NumPyro model's potential on its unconstrained space with
optimistix BFGS, takes the Hessian there and draws from N(mode, H⁻¹) through the model's
constraints. The residuals of both equations are correlated from sample to sample (the signals
are low-passed, and road bank and unmodelled dynamics vary slowly), so each equation's
likelihood is weighted by 1/VIF of its residuals at a first mode (:func:`residual_inflation`)
and the mode is found again: without it the intervals would count correlated samples as
independent and be several times too narrow.

Modules: :mod:`.search` (padding, the subsets a long drive is searched on), :mod:`.inflation`
(:func:`~.inflation.residual_inflation`), :mod:`.mode` (the whitened BFGS and the weighted mode),
:mod:`.sampling` (Laplace draws, NUTS) and :mod:`.posterior_checks` (identification, μ_y
observed, adequacy, the plot's partial slips); this one runs them in order.
"""

from __future__ import annotations

import json

import arviz_base as azb
import jax
import xarray as xr

from ..result import Fit, diagnose, provenance
from .data import CorneringObservations
from .mode import _constrain, _weighted_mode
from .model import SAMPLE_SITES, LateralPriors
from .posterior_checks import _adequacy, _identification, _mean_point, _partial_slips, _state_at
from .result import LateralFit
from .sampling import _covariance_root, _laplace, _nuts
from .search import _fit_stretches, _padded

#: The fitting methods (``"laplace"``: MAP + Laplace; ``"nuts"``: NUTS from the Laplace mode).
LATERAL_METHODS = ("laplace", "nuts")
#: The posterior's variables in the order of the fit's summary: the sample sites with the
#: understeer gradient (derived from the two stiffnesses) after them.
_SUMMARY_SITES = (*SAMPLE_SITES[:2], "understeer_gradient", *SAMPLE_SITES[2:])


def fit_lateral(
    obs: CorneringObservations,
    method: str = "laplace",
    *,
    priors: LateralPriors | None = None,
    surface: str = "dry",
    seed: int = 0,
    num_draws: int = 2000,
    num_chains: int = 2,
    num_warmup: int = 500,
    num_samples: int = 1000,
    max_steps: int = 3000,
    inputs: tuple[str, ...] = (),
) -> LateralFit:
    """Posterior of the per-axle cornering stiffness, understeer gradient, μ_y and nuisances.

    Parameters
    ----------
    obs : CorneringObservations
        From :func:`~tyrebayes.inference.lateral.data.cornering_observations`.
    method : {"laplace", "nuts"}
        MAP + Laplace (default; seconds), or NUTS started at the Laplace mode.
    priors : LateralPriors, optional
    surface : str
        Road surface: the centre of μ_y's prior.
    seed : int
        Randomness of the draws.
    num_draws : int
        Laplace draws.
    num_chains, num_warmup, num_samples : int
        NUTS settings.
    max_steps : int
        BFGS steps.
    inputs : tuple of str
        Where the data came from (the provenance).

    Returns
    -------
    LateralFit
        Not converged (optimiser failure, Hessian not positive definite, R-hat/ESS) and not
        adequate are said in its diagnostics, never raised. A drive of more than 21 minutes
        is fitted on its 21 minutes of 5 s stretches with the most cornering, some straight
        ones among them (:func:`~.search._fit_stretches`); the fit's attributes
        ``lateral_samples_read`` and ``lateral_samples_of_drive`` say how many samples it read.

    Examples
    --------
    >>> fit = fit_lateral(cornering_observations(frame, vehicle))  # doctest: +SKIP
    >>> fit.to_dict()["understeer_gradient"]["mean"]  # doctest: +SKIP
    """
    if method not in LATERAL_METHODS:
        raise ValueError(f"lateral fit method: expected one of {LATERAL_METHODS}, got {method!r}")
    priors = LateralPriors() if priors is None else priors
    drive_samples = obs.n_used
    obs = _padded(_fit_stretches(obs))
    key_draw, key_nuts = jax.random.split(jax.random.PRNGKey(seed))
    mode, ok, hess, weights, vif = _weighted_mode(obs, priors, surface, max_steps)
    chol, problems = _covariance_root(hess)
    if method == "laplace":
        samples = _laplace(mode, chol, obs, priors, key_draw, num_draws)
        sample_stats = None
        optimiser = "successful" if ok else "BFGS did not converge"
    else:
        init = {k: v[0] for k, v in _constrain(mode[None], obs, priors).items()}
        samples, sample_stats = _nuts(
            obs,
            priors,
            priors.mu_y_prior(surface),
            weights,
            init,
            key_nuts,
            (num_chains, num_warmup, num_samples),
        )
        optimiser = "n/a"
    names = [k for k in _SUMMARY_SITES if k in samples]
    groups = {"posterior": {k: samples[k] for k in names}}
    if sample_stats is not None:
        groups["sample_stats"] = sample_stats
    data = azb.from_dict(groups)
    flat_samples = {k: v.reshape((-1,) + v.shape[2:]) for k, v in samples.items()}
    state = _state_at(_mean_point(flat_samples), obs)
    data["constant_data"] = xr.DataTree(_partial_slips(obs, state, samples))
    identified, mu_observed, use = _identification(priors, surface, flat_samples, state, obs, seed)
    diagnostics = diagnose(
        data,
        method=method,
        var_names=[n for n in names if n != "understeer_gradient"],
        optimiser_result=optimiser,
        problems=problems,
    ).with_adequacy(_adequacy(obs, flat_samples, vif, priors))
    data.attrs["lateral_vif"] = json.dumps([float(v) for v in vif])
    # A long drive is fitted on its stretches with the most cornering (.search._fit_stretches).
    data.attrs["lateral_samples_read"] = obs.n_used
    data.attrs["lateral_samples_of_drive"] = drive_samples
    result = LateralFit(
        fit=Fit(
            data=data,
            diagnostics=diagnostics,
            kind="lateral",
            provenance=provenance(
                method,
                "single_track_magic",
                inputs,
                surface=surface,
                seed=seed,
                road_wheel=obs.road_wheel,
            ),
        ),
        mu_y_observed=mu_observed,
        identified=identified,
        cornering_seconds=float(obs.cornering_seconds),
        peak_use=use,
        road_wheel=obs.road_wheel,
    )
    result.fit.data.attrs.update(result.attrs())
    return result
