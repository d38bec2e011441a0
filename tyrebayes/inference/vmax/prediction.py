"""Predictive V_max [km/h] of the ISO 3888-2 lane change over draws of the tyre parameters.

Each draw runs the lane change's bisection on the critical speed (vmapped, compiled once per
vehicle, course, driver and tolerance): :func:`vmax_draws` on arrays, :func:`predict_vmax` on a
:class:`~tyrebayes.inference.vmax.inputs.VmaxInputs` into a :class:`VmaxPrediction`.

The search covers :data:`SEARCH_RANGE_KMH`. A draw whose car fails the course at the range's
lower end (a slippery road: V_max below 29 km/h, where the simulation cannot resolve it) or
passes at its upper end is censored: its value is that end, and it stays in the summaries, so
that a posterior most of whose mass lies below 29 km/h reads "at most a little above 29", never
the speeds of its few bracketed draws.
"""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ...physics.lanechange import (
    DEFAULT_DRIVER,
    SEARCH_RANGE_MPS,
    AxleTyres,
    Course,
    Driver,
    critical_speed,
    iso3888_2_course,
)
from ...physics.vehicle import Vehicle
from ..summary import summarize
from .inputs import VmaxInputs

#: The critical-speed search's ends [km/h]: a draw beyond one is censored there (module docstring).
SEARCH_RANGE_KMH = (3.6 * SEARCH_RANGE_MPS[0], 3.6 * SEARCH_RANGE_MPS[1])
# A bracketed draw lies at least half the bisection's last bracket inside the range; a censored
# one at its end, up to the draws' float precision.
_AT_END_KMH = 1e-3


def _vmax_batch(vehicle: Vehicle, course: Course, driver: Driver, tol_mps: float):
    low, high = SEARCH_RANGE_KMH

    def one(cf: Array, cr: Array, mu: Array) -> Array:
        cs = critical_speed(vehicle, AxleTyres(cf, cr, mu), course, driver, tol_mps=tol_mps)
        v = 0.5 * (cs.v_max_mps + cs.v_fail_mps) * 3.6
        # Failing at the lower end and passing at the upper one leaves no V_max at all.
        beyond = jnp.where(
            cs.below_range,
            jnp.where(cs.above_range, jnp.nan, low),
            jnp.where(cs.above_range, high, jnp.nan),
        )
        return jnp.where(cs.bracketed, v, beyond)

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
    """V_max [km/h] per parameter draw (vmapped bisection), censored at the search range's ends.

    A draw below :data:`SEARCH_RANGE_KMH` is its lower end, one above it its upper end
    (:func:`range_counts` counts them); NaN only where a run failed at the lower end and passed
    at the upper one.

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


def range_counts(v_max_kmh: Float[ArrayLike, "n"]) -> dict[str, int]:
    """How many draws of :func:`vmax_draws` lie below and above the search range, and how many
    have no V_max: ``{"below_range", "above_range", "undefined"}``.

    Examples
    --------
    >>> range_counts(np.array([SEARCH_RANGE_KMH[0], 55.0, SEARCH_RANGE_KMH[1], np.nan]))
    {'below_range': 1, 'above_range': 1, 'undefined': 1}
    """
    v = np.asarray(v_max_kmh, dtype=float)
    low, high = SEARCH_RANGE_KMH
    return {
        "below_range": int(np.sum(np.abs(v - low) < _AT_END_KMH)),
        "above_range": int(np.sum(np.abs(v - high) < _AT_END_KMH)),
        "undefined": int(np.sum(~np.isfinite(v))),
    }


@dataclasses.dataclass(frozen=True)
class VmaxPrediction:
    """Predictive V_max of the ISO 3888-2 lane change from :func:`predict_vmax`.

    Attributes
    ----------
    v_max_kmh : ndarray
        V_max per parameter draw [km/h]: at the search range's end for a draw beyond it, NaN
        where a draw has none (:func:`vmax_draws`).
    inputs : VmaxInputs
        The draws it ran on and their sources.
    vehicle : str
        The simulated vehicle's name (or file).

    Examples
    --------
    >>> from tyrebayes.inference.vmax.inputs import TYPE_SURFACE
    >>> c = np.full(3, 15.0)
    >>> x = VmaxInputs(c, c, np.full(3, 0.95), "type_prior", "type_prior", TYPE_SURFACE)
    >>> pred = VmaxPrediction(np.array([70.0, 74.0, np.nan]), x, "compact_fwd")
    >>> pred.not_bracketed, pred.summary()["mean"]
    (1, 72.0)
    >>> low = SEARCH_RANGE_KMH[0]
    >>> snow = VmaxPrediction(np.array([low, low, low, 31.0]), x, "compact_fwd")
    >>> snow.to_dict()["below_range"], snow.summary()["hdi_90"][0] == low
    (3, True)
    """

    v_max_kmh: np.ndarray
    inputs: VmaxInputs
    vehicle: str = ""

    @property
    def not_bracketed(self) -> int:
        """Draws whose V_max the search did not bracket: beyond its range or undefined."""
        return sum(range_counts(self.v_max_kmh).values())

    def summary(self) -> dict:
        """``{"mean", "sd", "hdi_90"}`` [km/h] over the draws with a V_max, those beyond the
        search range at its end: an interval end at a range end means "at or beyond", and the
        mean is then a bound."""
        return summarize(self.v_max_kmh).to_dict()

    def to_dict(self) -> dict:
        """``vmax FIT --json``'s object: ``v_max_kmh`` summary, the draws below and above the
        search range (``search_range_kmh``), sources and the inputs."""
        beyond = range_counts(self.v_max_kmh)
        return {
            "v_max_kmh": self.summary(),
            "vehicle": self.vehicle,
            "not_bracketed": sum(beyond.values()),
            **beyond,
            "search_range_kmh": list(SEARCH_RANGE_KMH),
            **self.inputs.to_dict(),
        }


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
        V_max per draw (censored at the ends of the 29-162 km/h search) and the sources.

    Examples
    --------
    >>> import jax
    >>> from tyrebayes._domain import load_vehicle
    >>> from tyrebayes.inference.vmax import type_vmax_inputs
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
