"""Friction energy rates, the Schallamach wear integral and relative wear (thesis chapter 4).

Thesis model (eq. 4.19, 4.24-4.28)::

    w_x = |F_x V_x sigma_x|,  w_y = |F_y V_x alpha|          energy rates [W]      (4.19a/b)
    I   = gamma * integral(w_x dt)                            wear volume [mm^3]    (4.26)
    sigma_x = rho_x / C_x  =>  w_x = rho_x^2 F_z |V_x| / C_x  linear-slip rate     (4.27 in 4.19a)
    I_rel = I_est / I_ref                                                          (4.28)

with the abrasability gamma in mm^3/J (Schallamach, eq. 4.9). The thesis' closed loop (Fig. 4.2)
feeds w_x into a tyre temperature model whose output sets C_x(T) through the stiffness compensation;
:func:`simulate_constant_traction` runs that loop with :mod:`tyrebayes.physics.thermal`.

Extension (this package): a temperature-dependent abrasability
``gamma(T) = gamma_ref exp(kappa (T - 20 °C))`` with a compound-dependent sensitivity kappa — the
thesis' own suggestion (Sec. 6.4: oxidative wear accelerates with temperature). kappa = 0 gives the
thesis model exactly.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ..internal.validation import check_in_range, check_positive
from .thermal import (
    REFERENCE_TEMPERATURE_C,
    StiffnessTemperature,
    ThermalParams,
    convective_conductance,
    rolling_loss_power,
    steady_state_temperature,
    stiffness_at_temperature,
)

Batch = Float[ArrayLike, "*#batch"]
Series = Float[ArrayLike, "n"]
ScalarOrSeries = Float[ArrayLike, ""] | Float[ArrayLike, "n"]


def energy_rate_longitudinal(fx_n: Batch, vx_mps: Batch, slip: Batch) -> Float[Array, "..."]:
    """Longitudinal friction energy rate w_x = |F_x V_x sigma_x| [W] (thesis eq. 4.19a).

    The sign is dropped as in the thesis: dissipation is positive in traction and braking.

    Examples
    --------
    >>> float(energy_rate_longitudinal(486.5, 27.5, 0.004))
    53.515
    """
    return jnp.abs(jnp.asarray(fx_n) * jnp.asarray(vx_mps) * jnp.asarray(slip))


def energy_rate_lateral(fy_n: Batch, vx_mps: Batch, alpha: Batch) -> Float[Array, "..."]:
    """Lateral friction energy rate w_y = |F_y V_x alpha| [W] (thesis eq. 4.19b, small angles).

    Examples
    --------
    >>> float(energy_rate_lateral(1000.0, 20.0, 0.01))
    200.0
    """
    return jnp.abs(jnp.asarray(fy_n) * jnp.asarray(vx_mps) * jnp.asarray(alpha))


def linear_slip_energy_rate(
    rho_x: Batch, fz_n: Batch, vx_mps: Batch, c_x: Batch
) -> Float[Array, "..."]:
    """w_x with linear slip sigma_x = rho_x / C_x (4.27 in 4.19a): rho_x^2 F_z |V_x| / C_x [W].

    Examples
    --------
    >>> round(float(linear_slip_energy_rate(0.1, 4865.0, 100 / 3.6, 29.0)), 2)
    46.6
    """
    rho = jnp.asarray(rho_x)
    return rho**2 * jnp.asarray(fz_n) * jnp.abs(jnp.asarray(vx_mps)) / jnp.asarray(c_x)


def wear_integral(
    time_s: Series, power_w: Series, gamma: Float[ArrayLike, ""] | Float[ArrayLike, "n"]
) -> Float[Array, ""]:
    """Wear volume I = integral(gamma w dt) by the trapezoid rule (thesis eq. 4.26) [mm^3].

    Parameters
    ----------
    time_s : Array, shape (n,)
        Sample times [s].
    power_w : Array, shape (n,)
        Friction energy rate w_x (+ w_y) [W].
    gamma : float or Array, shape (n,)
        Abrasability [mm^3/J]; a series when it varies with tyre temperature.

    Examples
    --------
    >>> float(wear_integral(jnp.array([0.0, 1.0, 2.0]), jnp.array([10.0, 10.0, 20.0]), 0.5))
    12.5
    """
    t = jnp.asarray(time_s, dtype=float)
    rate = jnp.asarray(gamma) * jnp.asarray(power_w)
    return jnp.sum(0.5 * (rate[1:] + rate[:-1]) * jnp.diff(t))


def relative_wear(i_est: Batch, i_ref: Batch) -> Float[Array, "..."]:
    """I_rel = I_est / I_ref (thesis eq. 4.28): expected over current-condition wear.

    Examples
    --------
    >>> float(relative_wear(3.0, 2.0))
    1.5
    """
    return jnp.asarray(i_est) / jnp.asarray(i_ref)


def relative_wear_difference(i_low: Batch, i_high: Batch) -> Float[Array, "..."]:
    """|I_high - I_low| / max(I_low, I_high), the form of the thesis' Fig. 6.7 (Sec. 6.2).

    Examples
    --------
    >>> float(relative_wear_difference(2.0, 3.0))
    0.3333333333333333
    """
    lo = jnp.asarray(i_low)
    hi = jnp.asarray(i_high)
    return jnp.abs(hi - lo) / jnp.maximum(lo, hi)


class Abrasability(eqx.Module):
    """Temperature-dependent abrasability gamma(T) = gamma_ref exp(kappa (T - T_ref)).

    Parameters
    ----------
    gamma_ref_mm3_per_j : float or Array
        Abrasability at the reference temperature [mm^3/J], > 0 (Schallamach, thesis eq. 4.9).
    temperature_sensitivity_per_k : float or Array
        kappa [1/K] in [-0.2, 0.2]; 0 is the thesis model. Compound dependent (soft winter
        compounds are expected to be more sensitive).
    reference_temperature_c : float or Array
        T_ref [°C], default 20 (the C_xr reference of thesis Sec. 3.3.1).

    Examples
    --------
    >>> a = Abrasability(0.02, 0.03)
    >>> round(float(abrasability_at_temperature(a, 30.0)), 5)
    0.027
    """

    gamma_ref_mm3_per_j: Batch
    temperature_sensitivity_per_k: Batch = 0.0
    reference_temperature_c: Batch = REFERENCE_TEMPERATURE_C

    def __check_init__(self):
        check_positive("Abrasability", "gamma_ref_mm3_per_j", self.gamma_ref_mm3_per_j)
        check_in_range(
            "Abrasability",
            "temperature_sensitivity_per_k",
            self.temperature_sensitivity_per_k,
            -0.2,
            0.2,
        )
        check_in_range(
            "Abrasability", "reference_temperature_c", self.reference_temperature_c, -60.0, 120.0
        )


def abrasability_at_temperature(abr: Abrasability, temp_c: Batch) -> Float[Array, "..."]:
    """gamma(T) [mm^3/J]; equals gamma_ref for every T when kappa = 0 (the thesis model)."""
    delta = jnp.asarray(temp_c) - abr.reference_temperature_c
    return abr.gamma_ref_mm3_per_j * jnp.exp(abr.temperature_sensitivity_per_k * delta)


class ConstantTractionRun(eqx.Module):
    """Result of the thesis' closed loop (Fig. 4.2) over time: one value per sample.

    Fields: ``time_s`` [s], ``tyre_temperature_c`` [°C], ``stiffness`` C_x(T) [-],
    ``slip`` [-], ``energy_rate_w`` w_x [W], ``rolling_loss_w`` [W].
    """

    time_s: Float[Array, "n"]
    tyre_temperature_c: Float[Array, "n"]
    stiffness: Float[Array, "n"]
    slip: Float[Array, "n"]
    energy_rate_w: Float[Array, "n"]
    rolling_loss_w: Float[Array, "n"]


def simulate_constant_traction(
    thermal: ThermalParams,
    comp: StiffnessTemperature,
    c_xr: Float[ArrayLike, ""],
    rho_x: ScalarOrSeries,
    fz_n: ScalarOrSeries,
    speed_mps: ScalarOrSeries,
    ambient_c: ScalarOrSeries,
    time_s: Series,
    initial_c: Float[ArrayLike, ""] | None = None,
) -> ConstantTractionRun:
    """The thesis' simulation environment (Sec. 4.5.1, Fig. 4.2) as a ``lax.scan``.

    Each step: C_x = C_x(T) (compensation), sigma = rho_x / C_x (4.27), w_x = F_x V sigma (4.19a),
    heat balance with rolling loss + eta w_x, tyre temperature relaxed over the step.

    Parameters
    ----------
    thermal, comp : ThermalParams, StiffnessTemperature
    c_xr : float
        Compensated stiffness C_xr at 20 °C [-].
    rho_x, fz_n, speed_mps, ambient_c : float or Array (n,)
        Normalised traction force [-], normal load [N], speed [m/s], ambient temperature [°C].
    time_s : Array (n,)
        Sample times [s].
    initial_c : float, optional
        Initial tyre temperature [°C]; default the first ambient temperature.

    Examples
    --------
    >>> run = simulate_constant_traction(ThermalParams(), StiffnessTemperature(), 29.0, 0.1,
    ...                                  4865.0, 100 / 3.6, 7.0, jnp.linspace(0, 3600, 361))
    >>> round(float(run.tyre_temperature_c[-1]), 1)
    32.3
    """
    t = jnp.asarray(time_s, dtype=float)
    n = t.shape[0]

    def series(x):
        return jnp.broadcast_to(jnp.asarray(x, dtype=float), (n,))

    rho, fz, v, amb = series(rho_x), series(fz_n), series(speed_mps), series(ambient_c)
    t0 = amb[0] if initial_c is None else jnp.asarray(initial_c, dtype=float)
    dt = jnp.concatenate([jnp.diff(t), jnp.zeros(1)])

    def step(temp, inputs):
        rho_k, fz_k, v_k, amb_k, dt_k = inputs
        c_x = stiffness_at_temperature(c_xr, temp, comp)
        w = linear_slip_energy_rate(rho_k, fz_k, v_k, c_x)
        target = steady_state_temperature(thermal, fz_k, v_k, w, amb_k)
        g = convective_conductance(thermal, v_k)
        new = target + (temp - target) * jnp.exp(-g * dt_k / thermal.heat_capacity_j_per_k)
        return new, (temp, c_x, rho_k / c_x, w)

    _, (temps, c_x, slip, w) = jax.lax.scan(step, t0, (rho, fz, v, amb, dt))
    rolling = thermal.rolling_resistance * fz * jnp.abs(v)
    return ConstantTractionRun(t, temps, c_x, slip, w, rolling)


def steady_constant_traction(
    thermal: ThermalParams,
    comp: StiffnessTemperature,
    c_xr: Batch,
    rho_x: Batch,
    fz_n: Batch,
    speed_mps: Batch,
    ambient_c: Batch,
    iterations: int = 30,
) -> tuple[Float[Array, "..."], Float[Array, "..."], Float[Array, "..."]]:
    """Steady state of the closed loop: (tyre temperature [°C], C_x [-], w_x [W]).

    Fixed-point iteration T <- T_amb + (P_roll + eta w_x(C_x(T))) / h(V); it contracts fast because
    d(eta w_x)/dT / h(V) is ~1e-3 (friction power is tiny next to the rolling loss).

    Examples
    --------
    >>> temp, c_x, w = steady_constant_traction(ThermalParams(), StiffnessTemperature(), 60.0,
    ...                                         0.1, 4865.0, 100 / 3.6, 40.0)
    >>> round(float(temp), 1), round(float(w), 1)
    (65.2, 33.8)
    """
    temp = jnp.asarray(ambient_c, dtype=float)
    for _ in range(iterations):
        c_x = stiffness_at_temperature(c_xr, temp, comp)
        w = linear_slip_energy_rate(rho_x, fz_n, speed_mps, c_x)
        temp = steady_state_temperature(thermal, fz_n, speed_mps, w, ambient_c)
    c_x = stiffness_at_temperature(c_xr, temp, comp)
    return temp, c_x, linear_slip_energy_rate(rho_x, fz_n, speed_mps, c_x)


def slip_work_kernel(
    rho_x: Batch, fz_n: Batch, speed_mps: Batch, dt_s: Batch
) -> Float[Array, "..."]:
    """Stiffness-free part of the friction work, k = rho_x^2 F_z |V| dt [J] (times C_x = work).

    Summed over a drive and divided by C_x it is the work W_x of eq. 4.25 under eq. 4.27. Keeping
    C_x out lets a model marginalise over an uncertain stiffness without re-reading the drive.
    """
    return linear_slip_energy_rate(rho_x, fz_n, speed_mps, 1.0) * jnp.asarray(dt_s)


def bin_by_temperature(
    weight: Series, temp_c: Series, grid_c: Float[ArrayLike, "b"]
) -> Float[Array, "b"]:
    """Spread per-sample weights onto a uniform temperature grid by linear interpolation.

    ``sum_b out[b] f(grid[b])`` approximates ``sum_t weight[t] f(temp[t])`` to second order in
    the grid step for smooth f (exact for f linear); samples outside the grid go to the end nodes.

    Examples
    --------
    >>> grid = jnp.arange(10.0, 14.0)
    >>> w = bin_by_temperature(jnp.array([1.0, 2.0]), jnp.array([10.5, 12.0]), grid)
    >>> w.tolist()
    [0.5, 0.5, 2.0, 0.0]
    """
    grid = jnp.asarray(grid_c, dtype=float)
    step = grid[1] - grid[0]
    pos = jnp.clip((jnp.asarray(temp_c) - grid[0]) / step, 0.0, grid.shape[0] - 1.0)
    lo = jnp.clip(jnp.floor(pos).astype(jnp.int32), 0, grid.shape[0] - 2)
    frac = pos - lo
    w = jnp.asarray(weight, dtype=float)
    out = jnp.zeros(grid.shape[0]).at[lo].add(w * (1.0 - frac))
    return out.at[lo + 1].add(w * frac)


# ---------------------------------------------------------------------------------------------
# Wear data: the tread band, per-drive friction-work features and the observations of a set.
# Types of the wear model's inputs (tyrebayes.inference.wear); simulate.wear makes them from a
# known truth, a real fleet's logs and workshop readings would make them from measurements.

#: Temperature grid of the binned friction-work features [°C] (1 K steps).
TEMPERATURE_GRID_C = np.arange(-30.0, 100.0, 1.0)


class TreadGeometry(eqx.Module):
    """Geometry and material of the tread band, converting wear volume to depth, mass and radius.

    Parameters
    ----------
    outer_radius_mm : float
        Unloaded outer radius [mm] (205/55R16: 8 in rim radius 203 mm + 0.55 * 205 mm = 316 mm).
    tread_width_mm : float
        Width of the wearing tread band [mm].
    void_fraction : float
        Groove share of the tread surface [-] in [0, 0.9) (~0.3 for car tyres).
    rubber_density_g_per_cm3 : float
        Tread compound density [g/cm^3] (~1.1-1.2 for filled rubber).
    new_depth_mm : float
        Tread depth of a new tyre [mm] (8 mm typical; legal limit 1.6 mm).
    radius_per_depth : float
        Rolling-radius loss per mm of tread depth lost [-] (assumed 1).
    """

    outer_radius_mm: float = 316.0
    tread_width_mm: float = 160.0
    void_fraction: float = 0.3
    rubber_density_g_per_cm3: float = 1.15
    new_depth_mm: float = 8.0
    radius_per_depth: float = 1.0

    def __check_init__(self):
        check_positive("TreadGeometry", "outer_radius_mm", self.outer_radius_mm)
        check_positive("TreadGeometry", "tread_width_mm", self.tread_width_mm)
        check_in_range("TreadGeometry", "void_fraction", self.void_fraction, 0.0, 0.9)
        check_positive("TreadGeometry", "rubber_density_g_per_cm3", self.rubber_density_g_per_cm3)
        check_positive("TreadGeometry", "new_depth_mm", self.new_depth_mm)
        check_positive("TreadGeometry", "radius_per_depth", self.radius_per_depth)

    @property
    def wear_area_mm2(self) -> float:
        """Rubber area over which the worn volume spreads, 2 pi R w (1 - void) [mm^2]."""
        return 2 * np.pi * self.outer_radius_mm * self.tread_width_mm * (1 - self.void_fraction)


def volume_to_depth_mm(volume_mm3: Float[ArrayLike, "..."], geom: TreadGeometry) -> Array:
    """Tread depth lost [mm] for a worn volume [mm^3] of one tyre.

    Examples
    --------
    >>> round(float(volume_to_depth_mm(20000.0, TreadGeometry())), 4)
    0.0899
    """
    return jnp.asarray(volume_mm3) / geom.wear_area_mm2


def volume_to_mass_g(volume_mm3: Float[ArrayLike, "..."], geom: TreadGeometry) -> Array:
    """Worn rubber mass [g] for a volume [mm^3] (1 cm^3 = 1000 mm^3)."""
    return jnp.asarray(volume_mm3) * geom.rubber_density_g_per_cm3 / 1000.0


class DriveWork(eqx.Module):
    """Friction-work features and true wear of a set of drives (D drives, 2 axles, B bins).

    ``kernel_binned[d, a, b]``: sum of rho^2 F_z V dt [J] of one wheel of axle a in drive d whose
    tyre temperature was near ``grid_c[b]``; the friction work is this over C_x(grid_c[b]).
    ``volume_mm3[d, a]``: the true worn volume of one wheel. ``tyre_temp_mean_c[d, a]``: the
    work-weighted mean tyre temperature.
    """

    distance_km: Float[Array, "d"]
    ambient_c: Float[Array, "d"]
    kernel_binned: Float[Array, "d 2 b"]
    grid_c: Float[Array, "b"]
    volume_mm3: Float[Array, "d 2"]
    tyre_temp_mean_c: Float[Array, "d 2"]


class WearObservations(eqx.Module):
    """Observations of one tyre set.

    ``depth_drive_index[j]``: the number of drives completed when depth reading j was taken;
    ``depth_axle[j]`` 0 front / 1 rear; ``depth_mm[j]`` the reading. ``radius_drift[d]``: relative
    rolling-radius difference (front - rear) / R_0 estimated from drive d's wheel speeds (after it).
    """

    depth_drive_index: Array
    depth_axle: Array
    depth_mm: Float[Array, "m"]
    radius_drift: Float[Array, "d"]
    depth_noise_mm: float = eqx.field(static=True)
    radius_noise: float = eqx.field(static=True)


def cumulative_depth_loss(
    volume_mm3: Float[ArrayLike, "d 2"], geom: TreadGeometry
) -> Float[Array, "d1 2"]:
    """Depth lost per axle after 0, 1, ..., D drives [mm] (first row zeros)."""
    cum = jnp.cumsum(jnp.asarray(volume_mm3), axis=0)
    return jnp.concatenate([jnp.zeros((1, 2)), volume_to_depth_mm(cum, geom)], axis=0)


# ---------------------------------------------------------------------------------------------
# The thesis' Table 6.1 simulation (Sec. 6.2), reproduced

_T_LOW, _T_HIGH = 7.0, 40.0
_TABLE_6_1 = {"speed_kmh": 100.0, "fz_n": 4865.0, "rho_x": 0.1}


def thesis_reproduction(c_soft: float = 29.0, c_stiff: float = 60.0) -> dict:
    """Steady states of the thesis' closed loop (Fig. 4.2) for the four Table 6.1 cases.

    A soft (C_xr 29) and a stiff (C_xr 60) tyre at 100 km/h, F_z 4865 N, rho_x 0.1, ambient 7 and
    40 °C: tyre temperature, C_x and energy rate of each case, and the relative wear difference
    |I_40 - I_7| / max per tyre (thesis Sec. 6.2). Returns a JSON-ready dict.
    """
    thermal, comp = ThermalParams(), StiffnessTemperature()
    v = _TABLE_6_1["speed_kmh"] / 3.6
    fz, rho = _TABLE_6_1["fz_n"], _TABLE_6_1["rho_x"]
    cases, rel = {}, {}
    for name, c_xr in (("soft", c_soft), ("stiff", c_stiff)):
        rates = {}
        for amb in (_T_LOW, _T_HIGH):
            temp, c_x, w = steady_constant_traction(thermal, comp, c_xr, rho, fz, v, amb)
            cases[f"{name}_{amb:g}C"] = {
                "c_xr": c_xr,
                "ambient_c": amb,
                "tyre_temperature_c": float(temp),
                "c_x": float(c_x),
                "energy_rate_w": float(w),
            }
            rates[amb] = w
        rel[name] = float(relative_wear_difference(rates[_T_LOW], rates[_T_HIGH]))
    return {
        "table_6_1": _TABLE_6_1,
        "cases": cases,
        "relative_wear_difference": rel,
        "rolling_loss_w": float(rolling_loss_power(thermal, fz, v)),
        "conductance_w_per_k": float(convective_conductance(thermal, v)),
        "soft_wears_relatively_more_in_heat": rel["soft"] > rel["stiff"],
    }
