"""The online estimator's parameter vector: the per-tyre model's sites in unconstrained form.

The recursive filter keeps a Gaussian over a fixed vector θ whose coordinates are the sites of
:func:`tyrebayes.inference.tyre.model.tyre_model` that a single car on a single surface has, each
mapped to the real line the way NumPyro's constraints would: log of a positive site, the site
itself where it is real. The prior of :class:`~tyrebayes.inference.tyre.model.TyrePriors` is then
exactly Gaussian in θ for every site (log-normal sites become normal), so the filter starts from
the type prior without approximation.

The per-drive force level and spread of the batch model are left out: they describe the
marginal of the measured slip-window forces and carry no information on C_x or μ_max (module
docstring of :mod:`tyrebayes.inference.tyre.model`).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from ...internal.renamed import renamed_keyword
from ..tyre.model import TyrePriors, check_model

# Site names in θ order. "log_" sites are positive in the model (θ = log of the site).
_COMMON_HEAD = ("log_c_xr", "temp_sensitivity", "log_mu_max", "abs_force_ratio")
_SHAPE = {
    "magic": ("log_curve_shape_excess", "log_curve_curvature_gap"),
    "shaped": ("log_curve_bend",),
    "brush": (),
    "linear": (),
}
_COMMON_TAIL = (
    "slip_offset",
    "log_force_gain",
    "log_rho_noise_scale",
    "log_slip_noise_scale",
    "log_slip_drift_sd",
)


#: θ's per-drive coordinates: each drive has its own in the batch model (a drive's rolling radii
#: and load share), so the filter starts them again from the prior at every drive start.
PER_DRIVE = ("slip_offset", "log_force_gain")
#: θ's coordinates the block log-likelihood is quadratic in given the others: the slip offset
#: shifts the Normal slip terms' location and the blocks' offsets' (the Laplace update takes no
#: new Hessian for a step along it, :mod:`.laplace_update`).
QUADRATIC = ("slip_offset",)
#: θ's coordinates that belong to the tyre (not to the drive or the sensors): what a swap renews.
TYRE_COORDINATES = (
    "log_c_xr",
    "temp_sensitivity",
    "load_sensitivity",
    "log_mu_max",
    "abs_force_ratio",
    "log_curve_shape_excess",
    "log_curve_curvature_gap",
    "log_curve_bend",
)
#: The tyre's coordinates the summary holds to the type prior besides C_xr (whose rule is the
#: readiness' own) and μ_max (held to its surface label): the curve's shape, the ABS force
#: ratio, the temperature and load sensitivities. Where the windows push one of them far out,
#: the model is explaining them with a tyre no prior allows (a wrong surface label sends the ABS
#: forces into the ratio and the shape), and no value of it is reported (:mod:`.summary`).
PRIOR_CHECKED = tuple(c for c in TYRE_COORDINATES if c not in ("log_c_xr", "log_mu_max"))


@renamed_keyword("kind", "model", what="the tyre-curve model")
def parameter_names(model: str, load_sensitive: bool = False) -> tuple[str, ...]:
    """Names of θ's coordinates for a tyre-curve ``model``
    (:data:`~tyrebayes.inference.tyre.curves.CURVE_MODELS`), with the load sensitivity q last
    where the priors have it (:attr:`TyrePriors.load_sensitive`).
    """
    check_model(model)
    return (
        *_COMMON_HEAD,
        *_SHAPE[model],
        *_COMMON_TAIL,
        *(("load_sensitivity",) if load_sensitive else ()),
    )


class GaussianPrior(eqx.Module):
    """A Gaussian over θ: the type prior the filter starts from and restarts at.

    Attributes
    ----------
    mean : Float[Array, "p"]
        Prior mean of θ (unconstrained coordinates, :func:`parameter_names`).
    cov : Float[Array, "p p"]
        Prior covariance of θ.
    model : str
        Tyre-curve model (static).
    surface : str
        Road surface whose μ_max prior it holds (static).
    load_sensitive : bool
        θ has the load sensitivity q (static; :func:`parameter_names`).
    """

    mean: Float[Array, "p"]
    cov: Float[Array, "p p"]
    model: str = eqx.field(static=True)
    surface: str = eqx.field(static=True)
    load_sensitive: bool = eqx.field(static=True, default=False)

    @property
    def names(self) -> tuple[str, ...]:
        """θ's coordinates (:func:`parameter_names`)."""
        return parameter_names(self.model, self.load_sensitive)

    def __check_init__(self):
        p = len(self.names)
        if self.mean.shape[-1] != p or self.cov.shape[-2:] != (p, p):
            raise ValueError(
                f"GaussianPrior: expected mean (…, {p}) and cov (…, {p}, {p}) for model "
                f"{self.model!r}, got {self.mean.shape} and {self.cov.shape}"
            )


@renamed_keyword("kind", "model", what="the tyre-curve model")
def type_prior(
    priors: TyrePriors | None = None,
    *,
    model: str = "magic",
    surface: str = "dry",
    imu_gain_log_sd: float = 0.0,
) -> GaussianPrior:
    """The Gaussian over θ that :class:`TyrePriors` implies for one car on one surface.

    Parameters
    ----------
    priors : TyrePriors, optional
        Prior scales (default :class:`TyrePriors`); ``slip_drift_median`` must be > 0 (the
        online update integrates each block's slip offset out, like the batch model).
    model : str
        Tyre-curve model, as for :func:`~tyrebayes.inference.tyre.fit.fit_tyre`.
    surface : str
        Road surface (sets μ_max's prior).
    imu_gain_log_sd : float
        Uncertainty of an IMU scale factor the stream pipeline divided the forces by; widens
        the force gain's prior as in the batch model.

    Examples
    --------
    >>> prior = type_prior(model="brush")
    >>> prior.mean.shape
    (9,)
    """
    priors = TyrePriors() if priors is None else priors
    check_model(model)
    if not priors.slip_drift_median > 0:
        raise ValueError(
            f"online estimator: expected slip_drift_median > 0, got {priors.slip_drift_median}"
        )
    moments = {
        "log_c_xr": (np.log(priors.c_xr_median), priors.c_xr_log_sd),
        "temp_sensitivity": (priors.temp_sensitivity_mean, priors.temp_sensitivity_sd),
        "load_sensitivity": (priors.load_sensitivity_mean, priors.load_sensitivity_sd),
        "log_mu_max": (
            float(np.log(priors.mu_median((surface,))[0])),
            float(priors.mu_log_sd((surface,))[0]),
        ),
        "abs_force_ratio": (priors.abs_force_ratio, priors.abs_force_ratio_sd),
        "log_curve_shape_excess": (
            priors.curve_shape_excess_log_mean,
            priors.curve_shape_excess_log_sd,
        ),
        "log_curve_curvature_gap": (
            priors.curve_curvature_log_mean,
            priors.curve_curvature_log_sd,
        ),
        "log_curve_bend": (np.log(priors.curve_bend_median), priors.curve_bend_log_sd),
        "slip_offset": (0.0, priors.slip_offset_sd),
        "log_force_gain": (0.0, float(np.hypot(priors.force_gain_log_sd, imu_gain_log_sd))),
        "log_rho_noise_scale": (0.0, priors.force_noise_log_sd),
        "log_slip_noise_scale": (0.0, priors.slip_noise_log_sd),
        "log_slip_drift_sd": (np.log(priors.slip_drift_median), priors.slip_drift_log_sd),
    }
    names = parameter_names(model, priors.load_sensitive)
    mean = jnp.asarray([moments[n][0] for n in names], dtype=float)
    sd = jnp.asarray([moments[n][1] for n in names], dtype=float)
    return GaussianPrior(
        mean=mean,
        cov=jnp.diag(sd**2),
        model=model,
        surface=surface,
        load_sensitive=priors.load_sensitive,
    )


def model_sites(theta: Float[Array, "p"], model: str, priors: TyrePriors | None = None) -> dict:
    """θ as the per-tyre model's sites by name (one drive, one surface), for ``window_likelihood``.

    The shape sites follow :func:`~tyrebayes.inference.tyre.model.tyre_model`'s deterministic
    maps (C = 1 + exp, E = 1 − exp for ``"magic"``; p = p_min + exp for ``"shaped"``).
    """
    priors = TyrePriors() if priors is None else priors
    names = parameter_names(model, priors.load_sensitive)
    value = {n: theta[i] for i, n in enumerate(names)}
    one = jnp.ones((1,), dtype=theta.dtype)
    sites = {
        "c_xr": jnp.exp(value["log_c_xr"]),
        "temp_sensitivity": value["temp_sensitivity"],
        "mu_max": one * jnp.exp(value["log_mu_max"]),
        "abs_force_ratio": value["abs_force_ratio"],
        "slip_offset": one * value["slip_offset"],
        "force_gain": one * jnp.exp(value["log_force_gain"]),
        # The slip windows' force marginal is not part of the online likelihood (module
        # docstring); these fill the sites window_likelihood reads for it.
        "force_level": 0.0 * one,
        "force_spread": one,
        "rho_noise_scale": jnp.exp(value["log_rho_noise_scale"]),
        "slip_noise_scale": jnp.exp(value["log_slip_noise_scale"]),
        "slip_drift_sd": jnp.exp(value["log_slip_drift_sd"]),
    }
    if priors.load_sensitive:
        sites["load_sensitivity"] = value["load_sensitivity"]
    if model == "magic":
        sites["curve_shape_c"] = 1.0 + jnp.exp(value["log_curve_shape_excess"])
        sites["curve_curvature_e"] = 1.0 - jnp.exp(value["log_curve_curvature_gap"])
    if model == "shaped":
        sites["curve_shape"] = priors.curve_shape_min + jnp.exp(value["log_curve_bend"])
    return sites


def reset_to_prior(
    prior: GaussianPrior,
    mean: Float[Array, "p"],
    cov: Float[Array, "p p"],
    names: tuple[str, ...],
    where: Bool[Array, ""],
) -> tuple[Float[Array, "p"], Float[Array, "p p"]]:
    """Where ``where``, the coordinates ``names`` take ``prior``'s marginal, uncorrelated with the
    rest (whose marginal is kept)."""
    chosen = jnp.asarray([n in names for n in prior.names]) & where
    either = chosen[:, None] | chosen[None, :]
    both = chosen[:, None] & chosen[None, :]
    cov = jnp.where(either, jnp.where(both, prior.cov, 0.0), cov)
    return jnp.where(chosen, prior.mean, mean), cov


__all__ = [
    "PER_DRIVE",
    "PRIOR_CHECKED",
    "TYRE_COORDINATES",
    "reset_to_prior",
    "GaussianPrior",
    "model_sites",
    "parameter_names",
    "type_prior",
]
