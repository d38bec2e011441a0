"""Predictive V_max of the ISO 3888-2 lane change, and the measured Table 6.2 as censored data.

Type-level relations (assumptions, stated because no cornering data exist for the thesis sets):

* lateral stiffness: C_y = k_type · C_xr [1/rad], k ~ LogNormal(log k_type, 0.15) with k_type =
  0.45 (winter), 0.40 (all-season), 0.35 (summer): softer winter treads lose less cornering
  stiffness per unit of longitudinal stiffness (block bending shares both);
* lateral friction on dry asphalt at 5-10 °C: μ_y = 0.95 · μ_x, μ_x ~ Normal(μ_type, 0.05) with
  μ_type = 0.95 (winter), 1.00 (all-season), 1.05 (summer).

Measured lateral parameters replace both relations where a fit carries a lateral posterior
(:func:`fit_vmax_inputs`): the per-axle c_y front and rear [1/rad over the static axle load]
enter the simulation as they are (:class:`~tyrebayes.physics.lanechange.AxleTyres`; C_f =
c_y_front · m g l_r / L N/rad), and μ_y is the lateral fit's where the drive neared the peak,
else the longitudinal μ_max where that fit observed it, else the lateral posterior's (the
surface's prior, bounded below by the forces the drive used). Each prediction says which
(:class:`VmaxInputs`: ``lateral_source`` "measured" / "fleet_type_ratio" / "type_prior",
``mu_y_source`` "measured" / "mu_max" / "surface_prior" / "type_prior"). A measured μ_y belongs to
the drive's surface; the type relations describe dry asphalt.

A set measured only in straight driving, in a fleet whose fit learnt the per-type ratio
k = c_y / C_xr (:func:`tyrebayes.inference.fleet.lateral_ratio_draws`), takes C_y = k · C_xr with
k drawn from its type's posterior predictive (``lateral_source`` "fleet_type_ratio",
:func:`fleet_ratio_vmax_inputs`) in place of the fixed k_type; μ_y stays the type relation's.

Measurements (thesis Table 6.2): the driver raised the speed in steps of 10 km/h until a cone fell,
so the recorded V_max means V ∈ [v_pass, v_pass + 10) km/h (interval censoring).

Models for the six measured sets:

* **driver-free**: V_i ~ Normal(m_i, s_i² + σ_rep²), (m_i, s_i) the simulation's predictive mean and
  sd, σ_rep = 2 km/h run-to-run repeatability, no free parameters;
* **extended**: V_i ~ Normal(m_i + δ − a (m_i − m̄), s_i² + σ_d²) with a driver offset
  δ ~ Normal(0, 20) km/h (a skilled driver beats the simple preview driver), an adaptation
  a ~ Normal(0, 1) (the fraction of the predicted tyre effect the driver compensates) and driver
  noise σ_d ~ HalfNormal(10) km/h, in NumPyro.
"""

from __future__ import annotations

import dataclasses
import functools
import json

import arviz_base as azb
import jax
import jax.numpy as jnp
import numpy as np
import numpyro
import numpyro.distributions as dist
import pandas as pd
from jax.scipy.special import ndtr
from jaxtyping import Array, ArrayLike, Float

from .._domain import load_lane_change_speeds
from ..physics.lanechange import (
    DEFAULT_DRIVER,
    AxleTyres,
    Course,
    Driver,
    critical_speed,
    iso3888_2_course,
)
from ..physics.vehicle import Vehicle
from .fleet.predict import has_lateral_ratio, lateral_ratio_draws, lateral_sets_per_type
from .lateral.result import LateralFit
from .nuts import run_nuts
from .result import Fit, diagnose, loo, provenance
from .summary import summarize
from .tyre.result import TyreFit

K_TYPE = {"winter": 0.45, "all_season": 0.40, "summer": 0.35}
MU_TYPE = {"winter": 0.95, "all_season": 1.00, "summer": 1.05}
MU_Y_RATIO = 0.95
SPEED_STEP_KMH = 10.0
REPEATABILITY_KMH = 2.0
#: Where a prediction's cornering stiffness came from: the fit's lateral posterior, the fleet's
#: per-type ratio (C_y = k · C_xr, k from the fleet fit's posterior predictive for the type), or
#: the type-level relation C_y = k_type · C_xr.
LATERAL_SOURCES = ("measured", "fleet_type_ratio", "type_prior")
#: Where its μ_y came from: the lateral fit (the drive neared the peak), the longitudinal fit's
#: observed μ_max, the lateral posterior without the peak (the surface's prior, bounded below by
#: the forces used), or the type relation μ_y = 0.95 μ_type.
MU_Y_SOURCES = ("measured", "mu_max", "surface_prior", "type_prior")
#: The surface the type relations describe.
TYPE_SURFACE = "dry asphalt (type relations)"


def load_table_6_2() -> pd.DataFrame:
    """The six ISO 3888-2 rows of the measured file (tyre, tyre_type, c_xr, v_max_kmh)."""
    return load_lane_change_speeds("thesis Table 6.2")


def lateral_draws(
    key: Array, c_xr: float, tyre_type: str, n: int
) -> tuple[Float[Array, "n"], Float[Array, "n"]]:
    """Draws of (C_y [1/rad], μ_y) for a tyre of measured C_xr via the type-level relations."""
    k1, k2 = jax.random.split(key)
    k = K_TYPE[tyre_type] * jnp.exp(0.15 * jax.random.normal(k1, (n,)))
    mu_x = MU_TYPE[tyre_type] + 0.05 * jax.random.normal(k2, (n,))
    return k * c_xr, MU_Y_RATIO * mu_x


def _vmax_batch(vehicle: Vehicle, course: Course, driver: Driver, tol_mps: float):
    def one(cf: Array, cr: Array, mu: Array) -> Array:
        cs = critical_speed(vehicle, AxleTyres(cf, cr, mu), course, driver, tol_mps=tol_mps)
        v = 0.5 * (cs.v_max_mps + cs.v_fail_mps) * 3.6
        return jnp.where(cs.bracketed, v, jnp.nan)

    return jax.jit(jax.vmap(one))


# One compiled program per vehicle, course, driver and tolerance (they are hashable modules of
# floats), so that the per-set and per-drive calls of a report or benchmark compile once.
_vmax_batch_cached = functools.lru_cache(maxsize=16)(_vmax_batch)


def vmax_draws(
    vehicle: Vehicle,
    c_y: Float[ArrayLike, "n"],
    mu_y: Float[ArrayLike, "n"],
    course: Course | None = None,
    driver: Driver = DEFAULT_DRIVER,
    tol_mps: float = 0.1,
    *,
    c_y_rear: Float[ArrayLike, "n"] | None = None,
) -> Float[Array, "n"]:
    """V_max [km/h] per parameter draw (vmapped bisection; NaN where not bracketed).

    ``c_y`` [1/rad] is both axles' normalised cornering stiffness, or the front axle's where
    ``c_y_rear`` is given (each over its static axle load, as the lateral fit reports them).

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> v = vmax_draws(load_vehicle("compact_fwd"), np.array([15.0]), np.array([0.95]))
    >>> v.shape, bool(40 < float(v[0]) < 90)
    ((1,), True)
    """
    course = iso3888_2_course(vehicle.width_m) if course is None else course
    c_front = jnp.asarray(c_y, dtype=float)
    c_rear = c_front if c_y_rear is None else jnp.asarray(c_y_rear, dtype=float)
    mu = jnp.asarray(mu_y, dtype=float)
    if not (c_front.shape == c_rear.shape == mu.shape and c_front.ndim == 1):
        raise ValueError(
            "vmax_draws: expected c_y, c_y_rear and mu_y of one shape (n,), got "
            f"{c_front.shape}, {c_rear.shape}, {mu.shape}"
        )
    try:
        batch = _vmax_batch_cached(vehicle, course, driver, float(tol_mps))
    except TypeError:  # a vehicle or course holding arrays is not hashable: compile for it
        batch = _vmax_batch(vehicle, course, driver, float(tol_mps))
    return batch(c_front, c_rear, mu)


@dataclasses.dataclass(frozen=True)
class VmaxInputs:
    """Joint draws of the lane change's tyre parameters, and where they came from.

    Attributes
    ----------
    c_y_front, c_y_rear : ndarray
        Per-axle cornering stiffness over the static axle load [1/rad] (equal on the type path).
    mu_y : ndarray
        Peak lateral friction at the static load [-].
    lateral_source : str
        One of :data:`LATERAL_SOURCES`.
    mu_y_source : str
        One of :data:`MU_Y_SOURCES`.
    surface : str
        The surface μ_y belongs to: the drive's, or :data:`TYPE_SURFACE`.
    note : str
        Why this source (e.g. the reason a fit has no lateral posterior); "" when nothing to say.

    Examples
    --------
    >>> c = np.array([14.0, 15.0, 16.0])
    >>> x = VmaxInputs(c, c, np.array([0.9, 0.95, 1.0]), "type_prior", "type_prior", TYPE_SURFACE)
    >>> x.n_draws, round(x.to_dict()["mu_y"]["mean"], 3)
    (3, 0.95)
    >>> VmaxInputs(c, c, c, "guess", "type_prior", TYPE_SURFACE)
    Traceback (most recent call last):
    ...
    ValueError: lateral_source: expected one of (...), got 'guess'
    """

    c_y_front: np.ndarray
    c_y_rear: np.ndarray
    mu_y: np.ndarray
    lateral_source: str
    mu_y_source: str
    surface: str
    note: str = ""

    def __post_init__(self) -> None:
        if self.lateral_source not in LATERAL_SOURCES:
            raise ValueError(
                f"lateral_source: expected one of {LATERAL_SOURCES}, got {self.lateral_source!r}"
            )
        if self.mu_y_source not in MU_Y_SOURCES:
            raise ValueError(
                f"mu_y_source: expected one of {MU_Y_SOURCES}, got {self.mu_y_source!r}"
            )
        shapes = {np.shape(self.c_y_front), np.shape(self.c_y_rear), np.shape(self.mu_y)}
        if len(shapes) != 1 or len(next(iter(shapes))) != 1:
            raise ValueError(f"VmaxInputs: expected draws of one shape (n,), got {sorted(shapes)}")

    @property
    def n_draws(self) -> int:
        return int(np.shape(self.mu_y)[0])

    def to_dict(self) -> dict:
        """Sources, surface, note and ``{"mean", "sd", "hdi_90"}`` of each parameter."""
        return {
            "lateral_source": self.lateral_source,
            "mu_y_source": self.mu_y_source,
            "surface": self.surface,
            "note": self.note,
            "c_y_front": summarize(self.c_y_front).to_dict(),
            "c_y_rear": summarize(self.c_y_rear).to_dict(),
            "mu_y": summarize(self.mu_y).to_dict(),
            "n_draws": self.n_draws,
        }


@dataclasses.dataclass(frozen=True)
class VmaxPrediction:
    """Predictive V_max of the ISO 3888-2 lane change from :func:`predict_vmax`.

    Attributes
    ----------
    v_max_kmh : ndarray
        V_max per parameter draw [km/h]; NaN where the bisection was not bracketed.
    inputs : VmaxInputs
        The draws it ran on and their sources.
    vehicle : str
        The simulated vehicle's name (or file).

    Examples
    --------
    >>> c = np.full(3, 15.0)
    >>> x = VmaxInputs(c, c, np.full(3, 0.95), "type_prior", "type_prior", TYPE_SURFACE)
    >>> pred = VmaxPrediction(np.array([70.0, 74.0, np.nan]), x, "compact_fwd")
    >>> pred.not_bracketed, pred.summary()["mean"]
    (1, 72.0)
    """

    v_max_kmh: np.ndarray
    inputs: VmaxInputs
    vehicle: str = ""

    @property
    def not_bracketed(self) -> int:
        return int(np.sum(~np.isfinite(self.v_max_kmh)))

    def summary(self) -> dict:
        """``{"mean", "sd", "hdi_90"}`` of the bracketed draws [km/h]."""
        return summarize(self.v_max_kmh).to_dict()

    def to_dict(self) -> dict:
        """``vmax FIT --json``'s object: ``v_max_kmh`` summary, sources and the inputs."""
        return {
            "v_max_kmh": self.summary(),
            "vehicle": self.vehicle,
            "not_bracketed": self.not_bracketed,
            **self.inputs.to_dict(),
        }


def _resample(key: Array, n_have: int, n: int) -> np.ndarray:
    """Indices of n draws out of n_have: without replacement where there are enough."""
    if n_have < 1:
        raise ValueError("expected at least one posterior draw, got none")
    if n <= n_have:
        return np.asarray(jax.random.permutation(key, n_have)[:n])
    return np.asarray(jax.random.randint(key, (n,), 0, n_have))


def type_vmax_inputs(key: Array, c_xr, tyre_type: str, n: int, note: str = "") -> VmaxInputs:
    """Draws of the type-level relations: C_y = k_type · C_xr on both axles, μ_y = 0.95 μ_type.

    Parameters
    ----------
    key : jax.Array
        PRNG key.
    c_xr : float or array_like
        The tyre's C_xr [-]: a value, or a fit's posterior draws (resampled with replacement).
    tyre_type : str
        One of ``winter``, ``all_season``, ``summer``.
    n : int
        Number of draws.
    note : str
        Why the type relations are used (carried into the result).

    Returns
    -------
    VmaxInputs
        ``lateral_source`` and ``mu_y_source`` ``"type_prior"``, surface :data:`TYPE_SURFACE`.

    Examples
    --------
    >>> import jax
    >>> x = type_vmax_inputs(jax.random.PRNGKey(0), 35.0, "all_season", 8)
    >>> x.lateral_source, x.mu_y_source, x.n_draws
    ('type_prior', 'type_prior', 8)
    """
    if tyre_type not in K_TYPE:
        raise ValueError(f"tyre_type: expected one of {tuple(K_TYPE)}, got {tyre_type!r}")
    k_ratio, mu_y = lateral_draws(key, 1.0, tyre_type, n)
    c = np.atleast_1d(np.asarray(c_xr, float))
    c_draws = c[np.asarray(jax.random.randint(jax.random.fold_in(key, 7), (n,), 0, c.size))]
    c_y = np.asarray(k_ratio) * c_draws
    return VmaxInputs(c_y, c_y, np.asarray(mu_y), "type_prior", "type_prior", TYPE_SURFACE, note)


def fleet_ratio_vmax_inputs(
    key: Array, fleet: Fit, c_xr, tyre_type: str, n: int, note: str = ""
) -> VmaxInputs:
    """Draws of C_y = k · C_xr on both axles with k from the fleet's ratio for the type.

    k is the fleet fit's posterior predictive for a new set of the type
    (:func:`tyrebayes.inference.fleet.lateral_ratio_draws`: the type's median ratio with its
    uncertainty and the set-to-set scatter); μ_y is the type relation's (0.95 μ_type), as in
    :func:`type_vmax_inputs`.

    Parameters
    ----------
    key : jax.Array
        PRNG key.
    fleet : Fit
        A fleet fit with the lateral ratio (a fleet table with ``c_y``).
    c_xr : float or array_like
        The set's C_xr [-]: a value, or its fit's posterior draws (resampled with replacement).
    tyre_type : str
        One of ``winter``, ``all_season``, ``summer``.
    n : int
        Number of draws.
    note : str
        Why no measured lateral posterior (carried into the result, with the ratio's sets).

    Returns
    -------
    VmaxInputs
        ``lateral_source`` ``"fleet_type_ratio"``, ``mu_y_source`` ``"type_prior"``.

    Examples
    --------
    >>> x = fleet_ratio_vmax_inputs(key, fleet_fit, 30.0, "winter", 400)  # doctest: +SKIP
    >>> x.lateral_source  # doctest: +SKIP
    'fleet_type_ratio'
    """
    if tyre_type not in K_TYPE:
        raise ValueError(f"tyre_type: expected one of {tuple(K_TYPE)}, got {tyre_type!r}")
    k_k, k_mu, k_c = jax.random.split(key, 3)
    seed = int(jax.random.randint(k_k, (), 0, 2**31 - 1))
    k_ratio = lateral_ratio_draws(fleet, tyre_type, n, seed=seed)
    _, mu_y = lateral_draws(k_mu, 1.0, tyre_type, n)
    c = np.atleast_1d(np.asarray(c_xr, float))
    c_draws = c[np.asarray(jax.random.randint(k_c, (n,), 0, c.size))]
    c_y = k_ratio * c_draws
    sets = lateral_sets_per_type(fleet).get(tyre_type, 0)
    learnt = (
        f"k = c_y / C_xr from the fleet's {sets} {tyre_type} set(s) with a lateral estimate"
        if sets
        else f"k = c_y / C_xr: the fleet had no {tyre_type} set with a lateral estimate (prior)"
    )
    note = f"{note}; {learnt}" if note else learnt
    return VmaxInputs(
        c_y, c_y, np.asarray(mu_y), "fleet_type_ratio", "type_prior", TYPE_SURFACE, note
    )


def lateral_vmax_inputs(
    key: Array,
    lateral: LateralFit,
    n: int,
    *,
    mu_max: np.ndarray | None = None,
    surface: str | None = None,
) -> VmaxInputs:
    """Draws of the measured per-axle c_y and of μ_y from a lateral posterior.

    c_y front, rear and μ_y are taken at the same posterior draws, which keeps their
    correlation (a steady drive measures the gradient well and the split poorly).

    Parameters
    ----------
    key : jax.Array
        PRNG key.
    lateral : LateralFit
        The lateral fit (:func:`~tyrebayes.inference.lateral.fit_lateral`).
    n : int
        Number of draws (without replacement where the posterior has as many).
    mu_max : array_like, optional
        Draws of μ_max from a longitudinal fit that observed its peak on this surface: used
        where the lateral fit did not observe μ_y (``mu_y_source`` ``"mu_max"``). Without it,
        an unobserved μ_y is the lateral posterior's own, the surface's prior bounded below by
        the forces the drive used (``"surface_prior"``).
    surface : str, optional
        The surface μ_y belongs to (default: the lateral fit's).

    Returns
    -------
    VmaxInputs
        ``lateral_source`` ``"measured"``; ``mu_y_source`` ``"measured"`` where
        ``lateral.mu_y_observed``, else as above, with a note saying so.
    """
    if surface is None:
        surface = str(json.loads(lateral.fit.provenance.settings).get("surface", "unknown"))
    c_f, c_r = lateral.draws("c_y_front"), lateral.draws("c_y_rear")
    mu = lateral.draws("mu_y")
    k_draw, k_mu = jax.random.split(key)
    idx = _resample(k_draw, c_f.shape[0], n)
    c_f, c_r, mu = c_f[idx], c_r[idx], mu[idx]
    if lateral.mu_y_observed:
        mu_source, note = "measured", ""
    elif mu_max is not None:
        mu_max = np.asarray(mu_max, float).ravel()
        mu = mu_max[_resample(k_mu, mu_max.size, n)]
        mu_source = "mu_max"
        note = "mu_y not observed (the drive did not near the lateral peak): mu_max used"
    else:
        mu_source = "surface_prior"
        note = (
            "mu_y not observed and no observed mu_max: the lateral posterior's mu_y, the "
            f"{surface} prior bounded below by the forces the drive used"
        )
    return VmaxInputs(c_f, c_r, mu, "measured", mu_source, surface, note)


def fit_vmax_inputs(
    fit: TyreFit,
    key: Array,
    n: int,
    tyre_type: str = "all_season",
    *,
    fleet: Fit | None = None,
) -> VmaxInputs:
    """The V_max inputs of a per-tyre fit: its lateral posterior if it has one, else the types'.

    A converged lateral posterior gives :func:`lateral_vmax_inputs` (with the fit's μ_max on
    its first surface where it observed that peak and the lateral fit did not observe μ_y);
    otherwise, given a fleet fit that learnt the per-type ratio c_y / C_xr, that ratio at the
    fit's C_xr draws (:func:`fleet_ratio_vmax_inputs`), else the type relations there
    (:func:`type_vmax_inputs`), with the reason in ``note`` (the fit's ``lateral_reason``, or
    the lateral fit's convergence failure).

    Parameters
    ----------
    fit : TyreFit
        A per-tyre fit (``fit-tyre --out``, read with ``TyreFit.from_fit(load_fit(path))``).
    key : jax.Array
        PRNG key.
    n : int
        Number of draws.
    tyre_type : str
        The tyre type of the type relations (used only without a lateral posterior).
    fleet : Fit, optional
        A fleet fit (:func:`tyrebayes.fit_fleet`); used only without a lateral posterior, and
        only where it carries the lateral ratio.

    Returns
    -------
    VmaxInputs

    Examples
    --------
    >>> inputs = fit_vmax_inputs(tyre_fit, key, 400, "winter", fleet=fleet_fit)  # doctest: +SKIP
    >>> inputs.lateral_source  # doctest: +SKIP
    'fleet_type_ratio'
    """
    lateral = fit.lateral
    surface = str(fit.surfaces[0])
    if lateral is not None and lateral.converged:
        mu_max = fit.draws("mu_max")[:, 0] if fit.mu_observed.get(surface, False) else None
        return lateral_vmax_inputs(key, lateral, n, mu_max=mu_max, surface=surface)
    if lateral is not None:
        why = "the lateral fit did not converge: " + "; ".join(lateral.fit.diagnostics.reasons)
    else:
        why = fit.lateral_reason or "the fit carries no lateral posterior"
    if fleet is not None and has_lateral_ratio(fleet):
        return fleet_ratio_vmax_inputs(key, fleet, fit.draws("c_xr"), tyre_type, n, note=why)
    return type_vmax_inputs(key, fit.draws("c_xr"), tyre_type, n, note=why)


def predict_vmax(
    vehicle: Vehicle,
    inputs: VmaxInputs,
    *,
    course: Course | None = None,
    driver: Driver = DEFAULT_DRIVER,
    tol_mps: float = 0.1,
    vehicle_name: str = "",
) -> VmaxPrediction:
    """Predictive V_max [km/h] of the ISO 3888-2 lane change over ``inputs``' draws.

    Parameters
    ----------
    vehicle : Vehicle
        The simulated car (its static axle loads turn each axle's c_y into N/rad).
    inputs : VmaxInputs
        From :func:`fit_vmax_inputs`, :func:`lateral_vmax_inputs`,
        :func:`fleet_ratio_vmax_inputs` or :func:`type_vmax_inputs`.
    course : Course, optional
        Default: :func:`~tyrebayes.physics.lanechange.iso3888_2_course` for the car's width.
    driver : Driver
        The preview driver.
    tol_mps : float
        Bisection tolerance [m/s].
    vehicle_name : str
        The car's name, carried into the result.

    Returns
    -------
    VmaxPrediction
        V_max per draw (NaN where the 29-162 km/h search did not bracket it) and the sources.

    Examples
    --------
    >>> import jax
    >>> from tyrebayes._domain import load_vehicle
    >>> inputs = type_vmax_inputs(jax.random.PRNGKey(0), 40.0, "all_season", 4)
    >>> pred = predict_vmax(load_vehicle("compact_fwd"), inputs)  # doctest: +SKIP
    >>> pred.to_dict()["lateral_source"]  # doctest: +SKIP
    'type_prior'
    """
    v = vmax_draws(
        vehicle,
        jnp.asarray(inputs.c_y_front),
        jnp.asarray(inputs.mu_y),
        course,
        driver,
        tol_mps,
        c_y_rear=jnp.asarray(inputs.c_y_rear),
    )
    return VmaxPrediction(np.asarray(v), inputs, vehicle_name)


def censored_loglik(
    lo_kmh: Float[Array, "n"], step_kmh: float, mean: Float[Array, "n"], sd: Float[Array, "n"]
) -> Float[Array, "n"]:
    """log P(lo ≤ V < lo + step) for V ~ Normal(mean, sd) (interval-censored observation)."""
    a = ndtr((lo_kmh - mean) / sd)
    b = ndtr((lo_kmh + step_kmh - mean) / sd)
    return jnp.log(jnp.clip(b - a, 1e-300, 1.0))


def extended_model(
    lo_kmh: Float[Array, "n"], m: Float[Array, "n"], s: Float[Array, "n"], step_kmh: float
) -> None:
    """NumPyro model: driver offset δ and driver noise σ_d on top of the simulation."""
    delta = numpyro.sample("delta_kmh", dist.Normal(0.0, 20.0))
    sigma = numpyro.sample("sigma_driver_kmh", dist.HalfNormal(10.0))
    # adaptation: the fraction of the predicted tyre effect the driver cancels (0 none, 1 all)
    adapt = numpyro.sample("adaptation", dist.Normal(0.0, 1.0))
    mean = m + delta - adapt * (m - jnp.mean(m))
    sd = jnp.sqrt(s**2 + sigma**2)
    ll = censored_loglik(lo_kmh, step_kmh, mean, sd)
    numpyro.deterministic("log_lik", ll)
    numpyro.factor("obs", jnp.sum(ll))


def fit_extended(
    lo_kmh: np.ndarray, m: np.ndarray, s: np.ndarray, seed: int = 0, num_samples: int = 1000
) -> Fit:
    """NUTS fit of :func:`extended_model` (one chain, 500 warm-up steps).

    Returns a :class:`~tyrebayes.inference.result.Fit` of kind ``"vmax"``: posterior
    ``delta_kmh``, ``sigma_driver_kmh``, ``adaptation``; ``log_likelihood["v_max"]`` per measured
    set (interval-censored); diagnostics under the package's policy (one chain: no R-hat).
    """
    run = run_nuts(
        extended_model,
        (jnp.asarray(lo_kmh), jnp.asarray(m), jnp.asarray(s), SPEED_STEP_KMH),
        seed=seed,
        num_warmup=500,
        num_samples=num_samples,
    )
    draws = dict(run.samples)
    log_lik = draws.pop("log_lik")
    data = azb.from_dict(
        {
            "posterior": draws,
            "log_likelihood": {"v_max": log_lik},
            "observed_data": {"v_max": np.asarray(lo_kmh, float)},
            "constant_data": {"predicted_mean": np.asarray(m), "predicted_sd": np.asarray(s)},
            "sample_stats": {"diverging": run.diverging},
        },
        dims={
            "v_max": ["measured_set"],
            "predicted_mean": ["measured_set"],
            "predicted_sd": ["measured_set"],
        },
    )
    return Fit(
        data=data,
        diagnostics=diagnose(data, method="nuts"),
        kind="vmax",
        provenance=provenance("nuts", "extended", ("lane-change intervals in memory",), seed=seed),
    )


def pointwise_log_lik(fit: Fit) -> np.ndarray:
    """The extended fit's log-likelihood per draw and measured set, (draws × n)."""
    values = np.asarray(fit.data["log_likelihood"]["v_max"])
    return values.reshape(-1, values.shape[-1])


def psis_loo(log_lik: np.ndarray) -> dict[str, float]:
    """PSIS-LOO elpd and its SE from a (draws × n) pointwise log-likelihood (arviz-stats)."""
    data = azb.from_dict(
        {
            "posterior": {"x": np.zeros((1, log_lik.shape[0]))},
            "log_likelihood": {"y": log_lik[None, :, :]},
        }
    )
    res = loo(data)
    return {
        "elpd_loo": float(res.elpd),
        "se": float(res.se),
        "pointwise": np.asarray(res.elpd_i).tolist(),
        "pareto_k_max": float(np.max(np.asarray(res.pareto_k))),
    }


def power_table(
    delta_kmh: float,
    sigma_kmh: float,
    steps_kmh: tuple[float, ...] = (10.0, 5.0, 2.0, 1.0),
    sessions: tuple[int, ...] = (1, 2, 3, 5, 10, 20),
    n_mc: int = 20000,
    seed: int = 0,
) -> list[dict[str, float]]:
    """P(the stiff set's mean recorded V_max exceeds the soft set's) per speed step and sessions.

    Each session is one staircase per set: true V = mean + Normal(0, σ) (driver/run noise), the
    recorded value is the last passed step floor(V/step)·step; the test "resolves" the difference
    when the mean over sessions of the stiff set is strictly larger.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for step in steps_kmh:
        for n in sessions:
            soft = rng.normal(70.0, sigma_kmh, (n_mc, n))
            stiff = rng.normal(70.0 + delta_kmh, sigma_kmh, (n_mc, n))
            phase = rng.uniform(0.0, step, (n_mc, 1))  # the step grid's phase, shared by both
            rec_soft = np.floor((soft - phase) / step).mean(axis=1)
            rec_stiff = np.floor((stiff - phase) / step).mean(axis=1)
            p_resolve = float(np.mean(rec_stiff > rec_soft))
            rows.append({"step_kmh": step, "sessions": n, "p_resolve": p_resolve})
    return rows
