"""Predictive V_max [km/h] of the ISO 3888-2 lane change over draws of the tyre parameters.

Each draw runs the lane change's bisection on the critical speed (vmapped, compiled once per
vehicle, course, driver and tolerance): :func:`vmax_draws` on arrays, :func:`predict_vmax` on a
:class:`~tyrebayes.inference.vmax.inputs.VmaxInputs` into a :class:`VmaxPrediction`.
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
    AxleTyres,
    Course,
    Driver,
    critical_speed,
    iso3888_2_course,
)
from ...physics.vehicle import Vehicle
from ..summary import summarize
from .inputs import VmaxInputs


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
    >>> from tyrebayes.inference.vmax.inputs import TYPE_SURFACE
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
