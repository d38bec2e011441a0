"""Lumped tyre temperature model and the stiffness temperature compensation C_x(T) <-> C_xr.

Heat balance of one tyre as a single thermal mass (the thesis' NIRA temperature model, chapter
4.5.1, is not published; this is a minimal physical stand-in with the same inputs)::

    C_th dT/dt = f_rr F_z |V|  +  eta |w_x|  -  h(V) (T - T_amb),      h(V) = h0 + h1 |V|^n

* ``f_rr F_z |V|`` — rolling-resistance (hysteresis) loss, almost all dissipated as heat in the
  rubber: ~1.35 kW per front tyre of the thesis' Table 6.1 car at 100 km/h.
* ``eta |w_x|`` — the share of the contact-patch friction power (thesis eq. 4.19a) that flows
  into the tyre (the rest heats the road). At Table 6.1 this is tens of watts, 30-60x less than
  hysteresis.
* ``h(V) (T - T_amb)`` — forced convection; the Nusselt number of a turbulent boundary layer grows
  as Re^0.8, hence the exponent n = 0.8.

The defaults put a tyre ~25 K above ambient at 100 km/h with a warm-up time constant of ~8 min,
typical of measured passenger-car tyre (inner-liner / air) temperatures; they are assumptions, to be
replaced by fitted values when a temperature sensor is available.

Stiffness compensation (thesis chapter 3.3.1: C_xr is C_x compensated to 20 °C)::

    C_x(T) = C_xr exp(-beta(C_xr) (T - 20)),      beta(C_xr) = beta_ref (C_xr / C_ref)^q

The sensitivity depends on the compound through its reference stiffness: q > 0 makes stiff
(summer) compounds change more in relative terms, which is what the thesis reports for NIRA's
compensation model (Sec. 6.2, Fig. 6.7); q < 0 makes soft compounds more sensitive; q = 0 gives one
sensitivity for all tyres. Its inverse (C_x at T -> C_xr) is solved by Newton's method in log space.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Bool, Float

from ..internal.validation import check_in_range, check_nonnegative, check_positive

Batch = Float[ArrayLike, "*#batch"]
Series = Float[ArrayLike, "n"]
ScalarOrSeries = Float[ArrayLike, ""] | Float[ArrayLike, "n"]

#: Reference temperature of the compensated stiffness C_xr (thesis Sec. 3.3.1) [°C].
REFERENCE_TEMPERATURE_C = 20.0


class ThermalParams(eqx.Module):
    """Parameters of the lumped tyre heat balance (one tyre; fields may be batched).

    Parameters
    ----------
    rolling_resistance : float or Array
        Rolling-resistance coefficient f_rr [-]; the hysteresis loss is f_rr F_z |V|. Default 0.010
        (EU label class C-E passenger tyres: 0.0075-0.0105).
    heat_capacity_j_per_k : float or Array
        Heat capacity of the thermally active mass C_th [J/K]. Default 2.5e4 (≈ 9 kg tyre at
        1.7 kJ/(kg K) plus part of the air and rim).
    convection_still_w_per_k : float or Array
        Conductance to ambient at standstill h0 [W/K]. Default 10.
    convection_speed_w_per_k : float or Array
        Speed coefficient h1 [W/K per (m/s)^n]. Default 3.1, so h(100 km/h) ≈ 54 W/K.
    convection_speed_exponent : float or Array
        Exponent n of the speed dependence [-], in [0, 1.5]. Default 0.8 (turbulent convection).
    friction_heat_fraction : float or Array
        Share eta of the contact friction power that heats the tyre, in [0, 1]. Default 0.5.

    Examples
    --------
    >>> p = ThermalParams()
    >>> round(float(steady_state_temperature(p, 4865.0, 27.78, 0.0, 20.0)))
    45
    """

    rolling_resistance: Batch = 0.010
    heat_capacity_j_per_k: Batch = 2.5e4
    convection_still_w_per_k: Batch = 10.0
    convection_speed_w_per_k: Batch = 3.1
    convection_speed_exponent: Batch = 0.8
    friction_heat_fraction: Batch = 0.5

    def __check_init__(self):
        check_positive("ThermalParams", "rolling_resistance", self.rolling_resistance)
        check_positive("ThermalParams", "heat_capacity_j_per_k", self.heat_capacity_j_per_k)
        check_positive("ThermalParams", "convection_still_w_per_k", self.convection_still_w_per_k)
        check_nonnegative(
            "ThermalParams", "convection_speed_w_per_k", self.convection_speed_w_per_k
        )
        check_in_range(
            "ThermalParams", "convection_speed_exponent", self.convection_speed_exponent, 0.0, 1.5
        )
        check_in_range(
            "ThermalParams", "friction_heat_fraction", self.friction_heat_fraction, 0.0, 1.0
        )


def convective_conductance(params: ThermalParams, speed_mps: Batch) -> Float[Array, "..."]:
    """Conductance to ambient h(V) = h0 + h1 |V|^n [W/K].

    The power law has an infinite slope at V = 0; the double-where keeps its gradient finite (0).

    Examples
    --------
    >>> round(float(convective_conductance(ThermalParams(), 27.78)), 1)
    54.3
    """
    v = jnp.abs(jnp.asarray(speed_mps, dtype=float))
    moving = v > 1e-9
    v_safe = jnp.where(moving, v, 1.0)
    power = jnp.where(moving, v_safe ** jnp.asarray(params.convection_speed_exponent), 0.0)
    return params.convection_still_w_per_k + params.convection_speed_w_per_k * power


def rolling_loss_power(params: ThermalParams, fz_n: Batch, speed_mps: Batch) -> Float[Array, "..."]:
    """Hysteresis heat of rolling, f_rr F_z |V| [W].

    Examples
    --------
    >>> round(float(rolling_loss_power(ThermalParams(), 4865.0, 100 / 3.6)))
    1351
    """
    return params.rolling_resistance * jnp.asarray(fz_n) * jnp.abs(jnp.asarray(speed_mps))


def heat_input_power(
    params: ThermalParams, fz_n: Batch, speed_mps: Batch, friction_power_w: Batch
) -> Float[Array, "..."]:
    """Total heat flowing into the tyre: hysteresis plus eta |friction power| [W]."""
    return rolling_loss_power(params, fz_n, speed_mps) + params.friction_heat_fraction * jnp.abs(
        jnp.asarray(friction_power_w)
    )


def steady_state_temperature(
    params: ThermalParams,
    fz_n: Batch,
    speed_mps: Batch,
    friction_power_w: Batch,
    ambient_c: Batch,
) -> Float[Array, "..."]:
    """Steady tyre temperature T = T_amb + P_in / h(V) [°C].

    Parameters
    ----------
    params : ThermalParams
    fz_n : array_like
        Normal load on the tyre [N].
    speed_mps : array_like
        Vehicle speed V_x [m/s].
    friction_power_w : array_like
        Contact friction power w_x (+ w_y) of this tyre [W] (thesis eq. 4.19).
    ambient_c : array_like
        Ambient temperature [°C].

    Returns
    -------
    Array
        Tyre temperature [°C].

    Examples
    --------
    >>> t = steady_state_temperature(ThermalParams(), 4865.0, 27.78, 46.6, 7.0)
    >>> round(float(t), 1)
    32.3
    """
    p_in = heat_input_power(params, fz_n, speed_mps, friction_power_w)
    return jnp.asarray(ambient_c) + p_in / convective_conductance(params, speed_mps)


def _relax(temp, target, conductance, heat_capacity, dt):
    # Exact solution of the linear ODE over a step with inputs held: unconditionally stable and
    # exact for constant inputs, so steady state is reached to round-off whatever dt is.
    decay = jnp.exp(-conductance * dt / heat_capacity)
    return target + (temp - target) * decay


def simulate_tyre_temperature(
    params: ThermalParams,
    time_s: Series,
    speed_mps: ScalarOrSeries,
    fz_n: ScalarOrSeries,
    friction_power_w: ScalarOrSeries,
    ambient_c: ScalarOrSeries,
    initial_c: Float[ArrayLike, ""],
) -> Float[Array, "n"]:
    """Integrate the lumped heat balance over a time series (``jax.lax.scan``, differentiable).

    Inputs are held constant over each interval [t_k, t_{k+1}) (zero-order hold) and each step uses
    the exact exponential solution, so the result does not depend on the step size for constant
    inputs.

    Parameters
    ----------
    params : ThermalParams
    time_s : Array, shape (n,)
        Strictly increasing sample times [s].
    speed_mps, fz_n, friction_power_w, ambient_c : array_like, scalar or shape (n,)
        Speed [m/s], normal load [N], friction power [W], ambient temperature [°C].
    initial_c : float
        Tyre temperature at ``time_s[0]`` [°C].

    Returns
    -------
    Array, shape (n,)
        Tyre temperature at each sample time [°C].

    Examples
    --------
    >>> t = jnp.linspace(0.0, 7200.0, 721)
    >>> temp = simulate_tyre_temperature(ThermalParams(), t, 27.78, 4865.0, 0.0, 7.0, 7.0)
    >>> round(float(temp[-1]), 1)
    31.9
    """
    time_s = jnp.asarray(time_s, dtype=float)
    n = time_s.shape[0]
    shape = (n,)
    target = jnp.broadcast_to(
        steady_state_temperature(params, fz_n, speed_mps, friction_power_w, ambient_c), shape
    )
    conductance = jnp.broadcast_to(convective_conductance(params, speed_mps), shape)
    dt = jnp.diff(time_s)

    def step(temp, inputs):
        target_k, g_k, dt_k = inputs
        new = _relax(temp, target_k, g_k, params.heat_capacity_j_per_k, dt_k)
        return new, new

    t0 = jnp.asarray(initial_c, dtype=float)
    _, rest = jax.lax.scan(step, t0, (target[:-1], conductance[:-1], dt))
    return jnp.concatenate([t0[None], rest])


class StiffnessTemperature(eqx.Module):
    """Temperature compensation of the longitudinal slip stiffness, C_x(T) <-> C_xr at 20 °C.

    ``C_x(T) = C_xr exp(-beta(C_xr) (T - T_ref))`` with ``beta(C_xr) = beta_ref (C_xr / C_ref)^q``.

    Parameters
    ----------
    sensitivity_per_k : float or Array
        beta_ref, the relative stiffness loss per kelvin of a tyre with C_xr = C_ref [1/K], >= 0.
        Default 0.006 (C_x falls ~18 % from 20 °C to 50 °C).
    reference_stiffness : float or Array
        C_ref [-], > 0. Default 40 (between winter ~30 and summer ~55).
    stiffness_exponent : float or Array
        q [-] in [-2, 2]; compound dependence of the sensitivity. Default 1 (stiffer compounds
        relatively more sensitive, as the thesis reports for NIRA's model, Sec. 6.2).
    reference_temperature_c : float or Array
        T_ref [°C]. Default 20 (thesis Sec. 3.3.1).

    Examples
    --------
    >>> comp = StiffnessTemperature()
    >>> round(float(stiffness_at_temperature(60.0, 40.0, comp)), 2)
    50.12
    """

    sensitivity_per_k: Batch = 0.006
    reference_stiffness: Batch = 40.0
    stiffness_exponent: Batch = 1.0
    reference_temperature_c: Batch = REFERENCE_TEMPERATURE_C

    def __check_init__(self):
        check_nonnegative("StiffnessTemperature", "sensitivity_per_k", self.sensitivity_per_k)
        check_positive("StiffnessTemperature", "reference_stiffness", self.reference_stiffness)
        check_in_range(
            "StiffnessTemperature", "stiffness_exponent", self.stiffness_exponent, -2.0, 2.0
        )
        check_in_range(
            "StiffnessTemperature",
            "reference_temperature_c",
            self.reference_temperature_c,
            -60.0,
            120.0,
        )


def temperature_sensitivity(c_xr: Batch, comp: StiffnessTemperature) -> Float[Array, "..."]:
    """beta(C_xr) = beta_ref (C_xr / C_ref)^q, relative stiffness change per kelvin [1/K].

    Examples
    --------
    >>> round(float(temperature_sensitivity(20.0, StiffnessTemperature())), 4)
    0.003
    """
    ratio = jnp.asarray(c_xr, dtype=float) / comp.reference_stiffness
    return comp.sensitivity_per_k * ratio ** jnp.asarray(comp.stiffness_exponent)


def stiffness_with_sensitivity(
    c_xr: Batch,
    temp_c: Batch,
    sensitivity_per_k: Batch,
    reference_temperature_c: Batch = REFERENCE_TEMPERATURE_C,
) -> Float[Array, "..."]:
    """C_x(T) = C_xr exp(-kappa (T - T_ref)) for a given sensitivity kappa (thesis Sec. 3.3.1).

    The compensation law itself; :func:`stiffness_at_temperature` feeds it the compound-dependent
    kappa of a :class:`StiffnessTemperature`, the tyre fit an inferred one.

    Parameters
    ----------
    c_xr : array_like
        Compensated longitudinal stiffness C_xr [-].
    temp_c : array_like
        Tyre temperature [°C].
    sensitivity_per_k : array_like
        Relative stiffness loss per kelvin, kappa [1/K].
    reference_temperature_c : array_like
        T_ref [°C], default 20.

    Returns
    -------
    Array
        C_x(T) [-].

    Examples
    --------
    >>> round(float(stiffness_with_sensitivity(40.0, 30.0, 0.01)), 4)
    36.1935
    """
    delta = jnp.asarray(temp_c) - reference_temperature_c
    return jnp.asarray(c_xr, dtype=float) * jnp.exp(-jnp.asarray(sensitivity_per_k) * delta)


def stiffness_at_temperature(
    c_xr: Batch, temp_c: Batch, comp: StiffnessTemperature
) -> Float[Array, "..."]:
    """Stiffness C_x at tyre temperature T from the compensated stiffness C_xr (at 20 °C).

    Parameters
    ----------
    c_xr : array_like
        Compensated longitudinal stiffness C_xr [-] (thesis Sec. 3.3.1).
    temp_c : array_like
        Tyre temperature [°C].
    comp : StiffnessTemperature

    Returns
    -------
    Array
        C_x(T) [-].

    Examples
    --------
    >>> round(float(stiffness_at_temperature(29.0, 20.0, StiffnessTemperature())), 6)
    29.0
    """
    c_xr = jnp.asarray(c_xr, dtype=float)
    return stiffness_with_sensitivity(
        c_xr, temp_c, temperature_sensitivity(c_xr, comp), comp.reference_temperature_c
    )


def compensation_is_invertible(
    c_xr: Batch, temp_c: Batch, comp: StiffnessTemperature
) -> Bool[Array, "..."]:
    """Whether (C_xr, T) lies where C_x(C_xr) is monotone: q beta(C_xr) (T - T_ref) < 1.

    Outside this region two C_xr give the same C_x and :func:`compensate_stiffness` is not
    meaningful; callers should check it (it is a boolean array, usable under jit).

    Examples
    --------
    >>> bool(compensation_is_invertible(60.0, 70.0, StiffnessTemperature(stiffness_exponent=2.0)))
    False
    """
    delta = jnp.asarray(temp_c) - comp.reference_temperature_c
    return comp.stiffness_exponent * temperature_sensitivity(c_xr, comp) * delta < 1.0


def compensate_stiffness(
    c_x: Batch,
    temp_c: Batch,
    comp: StiffnessTemperature,
    iterations: int = 8,
) -> Float[Array, "..."]:
    """Compensated stiffness C_xr from a stiffness C_x measured at tyre temperature T.

    Inverse of :func:`stiffness_at_temperature`. With u = ln C_xr it solves
    ``u - beta_ref exp(q (u - ln C_ref)) (T - T_ref) = ln C_x`` by Newton's method (a fixed number
    of unrolled steps, so it is jit/vmap/grad safe; q = 0 is solved exactly by the first step). The
    map is monotone, hence invertible, while ``q beta(C_xr) |T - T_ref| < 1`` (0.72 at the
    defaults, C_xr = 60 and 80 K away from 20 °C).

    Examples
    --------
    >>> comp = StiffnessTemperature()
    >>> c_x = stiffness_at_temperature(60.0, 45.0, comp)
    >>> round(float(compensate_stiffness(c_x, 45.0, comp)), 6)
    60.0
    """
    v = jnp.log(jnp.asarray(c_x, dtype=float))
    delta = jnp.asarray(temp_c) - comp.reference_temperature_c
    q = jnp.asarray(comp.stiffness_exponent)
    log_ref = jnp.log(jnp.asarray(comp.reference_stiffness, dtype=float))

    def beta_of(u):
        return comp.sensitivity_per_k * jnp.exp(q * (u - log_ref))

    u = v + beta_of(v) * delta
    for _ in range(iterations):
        b = beta_of(u)
        residual = u - b * delta - v
        slope = 1.0 - q * b * delta
        u = u - residual / slope
    return jnp.exp(u)
