"""ISO 3888-2 double lane change: course, closed-loop single-track simulation, critical speed.

Course (ISO 3888-2:2011, obstacle-avoidance "moose" course; w = vehicle width [m]):

======  ==========  ===============================  ========
section length [m]  lane width [m]                   role
======  ==========  ===============================  ========
1       12.0        1.1 w + 0.25                     entry lane (throttle released here)
2       13.5        --                               lane change
3       11.0        w + 1.0                          side lane, offset 1.0 m to the left
4       12.5        --                               lane change back
5       12.0        1.3 w + 0.25 (thesis Sec. 5.3: 3 m)  exit lane
======  ==========  ===============================  ========

Geometry assumption (stated, as the standard's figure shows it): lanes 1 and 5 share their
right-hand boundary (y = 0); lane 3's right boundary lies 1.0 m left of lane 1's left boundary.

Model: single-track dynamics (thesis eq. 4.22/4.23, as in :mod:`tyrebayes.physics.vehicle`),
lateral brush tyres per wheel (:func:`tyrebayes.physics.tyre.brush_lateral`) with lateral load
transfer and a load-sensitive friction coefficient, so the more loaded outer wheel saturates first
and the axle's effective friction falls with a_y. Driver: pure-pursuit preview of a reference path
(boundary-hugging lane lines joined by cosine blends) with a reaction lag (first-order, time
constant ``reaction_s``, a stand-in for a pure delay that keeps the fixed-step scan small), a
steering-rate and a steering-angle limit. Throttle is released at entry: the car coasts down under
aerodynamic drag and rolling resistance. A run fails when any corner of the body rectangle leaves a
gated lane (sections 1, 3, 5) or the car does not reach the end of the course.

Sensitivities: :func:`critical_speed_sensitivity` uses implicit differentiation of the footprint
margin at V_max (checked against finite differences of the bisection in ``benchmarks/vmax.py``).

Examples
--------
>>> from tyrebayes._domain import load_vehicle
>>> veh = load_vehicle("compact_fwd")
>>> bool(run_margin(veh, Tyres(16.0, 0.95), 10.0, iso3888_2_course(veh.width_m)) > 0)
True
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Bool, Float

from .tyre import brush_lateral
from .vehicle import GRAVITY_MPS2, Vehicle, aero_drag, rolling_resistance_force

SECTION_LENGTHS_M = (12.0, 13.5, 11.0, 12.5, 12.0)
LATERAL_OFFSET_M = 1.0
THESIS_EXIT_WIDTH_M = 3.0


class Course(eqx.Module):
    """Gated lanes of the ISO 3888-2 course, x along the course [m], y to the left [m].

    Examples
    --------
    >>> c = iso3888_2_course(1.8)
    >>> round(c.lane1_width_m, 3), round(c.lane3_width_m, 3), c.x_edges_m[-1]
    (2.23, 2.8, 61.0)
    """

    vehicle_width_m: float
    lane1_width_m: float
    lane3_width_m: float
    lane5_width_m: float
    x_edges_m: tuple[float, ...]

    def __check_init__(self) -> None:
        if not self.vehicle_width_m > 0:
            raise ValueError(f"vehicle_width_m must be > 0, got {self.vehicle_width_m}")

    @property
    def lane_bounds(self) -> tuple[tuple[float, float, float, float], ...]:
        """(x_start, x_end, y_right, y_left) [m] of the three gated lanes."""
        e, w1 = self.x_edges_m, self.lane1_width_m
        y3 = w1 + LATERAL_OFFSET_M
        return (
            (e[0], e[1], 0.0, w1),
            (e[2], e[3], y3, y3 + self.lane3_width_m),
            (e[4], e[5], 0.0, self.lane5_width_m),
        )


def iso3888_2_course(vehicle_width_m: float, exit_lane: str = "thesis") -> Course:
    """ISO 3888-2:2011 course for a vehicle of the given width [m].

    Parameters
    ----------
    vehicle_width_m : float
        The vehicle's width w [m]; the entry lane is 1.1 w + 0.25 m wide, the middle lane
        w + 1 m.
    exit_lane : {"thesis", "standard"}
        ``"standard"`` uses 1.3 w + 0.25 m; ``"thesis"`` uses the thesis' 3 m (Sec. 5.3).

    Returns
    -------
    Course

    Examples
    --------
    >>> course = iso3888_2_course(1.8)
    >>> round(course.lane1_width_m, 2), course.lane3_width_m
    (2.23, 2.8)
    """
    if exit_lane not in ("standard", "thesis"):
        raise ValueError(f"exit_lane must be 'standard' or 'thesis', got {exit_lane!r}")
    w = float(vehicle_width_m)
    edges = [0.0]
    for length in SECTION_LENGTHS_M:
        edges.append(edges[-1] + length)
    w5 = 1.3 * w + 0.25 if exit_lane == "standard" else THESIS_EXIT_WIDTH_M
    return Course(w, 1.1 * w + 0.25, w + 1.0, w5, tuple(edges))


class Driver(eqx.Module):
    """Preview path-following driver. Times [s], angles road-wheel [rad], rates [rad/s]."""

    preview_s: float = 0.5
    reaction_s: float = 0.05  # skilled test driver; V_max is very sensitive to this (see benchmark)
    max_steer_rate_radps: float = 1.0  # ~ 900 deg/s at the hand wheel for ratio 16
    max_steer_rad: float = 0.5


DEFAULT_DRIVER = Driver()


class Tyres(eqx.Module):
    """Lateral tyre parameters: normalised cornering stiffness C_y [1/rad], peak friction μ_y,
    and friction load sensitivity (μ_i = μ_y (1 − k (F_z,i/F_z,static − 1))).

    One C_y on both axles (the type-level relation C_y = k_type · C_xr); :class:`AxleTyres`
    carries a measured stiffness per axle.
    """

    c_y: Float[ArrayLike, ""]
    mu_y: Float[ArrayLike, ""]
    load_sensitivity: float = 0.1

    @property
    def c_y_front(self) -> Float[ArrayLike, ""]:
        return self.c_y

    @property
    def c_y_rear(self) -> Float[ArrayLike, ""]:
        return self.c_y


class AxleTyres(eqx.Module):
    """Lateral tyre parameters per axle, as the lateral fit measures them.

    ``c_y_front`` and ``c_y_rear`` [1/rad] are each axle's cornering stiffness over its static
    axle load (thesis eq. 5.5 over F_z), so the axle's stiffness in N/rad is C_f = c_y_front ·
    m g l_r / L and C_r = c_y_rear · m g l_f / L (:meth:`cornering_stiffness_n_per_rad`). The
    simulation's axle force is the sum of its two wheels' F_z,i ρ_y(α; c_y, μ_i); load transfer
    moves load between them but keeps their sum, so the axle's slope at α = 0 is exactly that C.
    μ_y [-] is the peak at the static load, with the load sensitivity of :class:`Tyres`.

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> veh = load_vehicle("compact_fwd")
    >>> c_f, c_r = AxleTyres(14.0, 17.0, 1.0).cornering_stiffness_n_per_rad(veh)
    >>> bool(c_f > 0 and c_r > 0)
    True
    """

    c_y_front: Float[ArrayLike, ""]
    c_y_rear: Float[ArrayLike, ""]
    mu_y: Float[ArrayLike, ""]
    load_sensitivity: float = 0.1

    def cornering_stiffness_n_per_rad(
        self, vehicle: Vehicle
    ) -> tuple[Float[Array, ""], Float[Array, ""]]:
        """(C_f, C_r) [N/rad]: each axle's c_y times its static load m g l_r/L, m g l_f/L."""
        fz_f, fz_r = static_axle_loads(vehicle)
        return jnp.asarray(self.c_y_front) * fz_f, jnp.asarray(self.c_y_rear) * fz_r

    @classmethod
    def from_cornering_stiffness(
        cls,
        vehicle: Vehicle,
        c_front_n_per_rad: Float[ArrayLike, ""],
        c_rear_n_per_rad: Float[ArrayLike, ""],
        mu_y: Float[ArrayLike, ""],
        load_sensitivity: float = 0.1,
    ) -> AxleTyres:
        """From axle stiffnesses in N/rad (the inverse of :meth:`cornering_stiffness_n_per_rad`)."""
        fz_f, fz_r = static_axle_loads(vehicle)
        return cls(
            jnp.asarray(c_front_n_per_rad) / fz_f,
            jnp.asarray(c_rear_n_per_rad) / fz_r,
            mu_y,
            load_sensitivity,
        )


def static_axle_loads(vehicle: Vehicle) -> tuple[float, float]:
    """Static axle loads (F_z,f, F_z,r) = (m g l_r/L, m g l_f/L) [N]."""
    m, wb = vehicle.mass_kg, vehicle.wheelbase_m
    return (
        m * GRAVITY_MPS2 * vehicle.cog_to_rear_axle_m / wb,
        m * GRAVITY_MPS2 * vehicle.cog_to_front_axle_m / wb,
    )


def _centre_path(course: Course, x: Array, lead_m: float = 0.0) -> Array:
    """Reference y(x) of the CoG: boundary-hugging lane lines joined by cosine blends."""
    (a0, a1, r1, l1), (b0, b1, r3, l3), (c0, c1, r5, l5) = course.lane_bounds
    # a driver keeps to the inside of lanes 1 and 3 to shorten the lane changes; lane 3 is
    # 0.55 m wider than lane 1 so it gets more clearance (0.35 vs 0.2 m) for overshoot
    half = 0.5 * course.vehicle_width_m
    y1, y3, y5 = l1 - half - 0.2, r3 + half + 0.35, 0.5 * (r5 + l5)

    def blend(xx: Array, x0: float, x1: float, ya: float, yb: float) -> Array:
        s = jnp.clip((xx - x0) / (x1 - x0), 0.0, 1.0)
        return ya + (yb - ya) * 0.5 * (1.0 - jnp.cos(jnp.pi * s))

    # the preview makes the driver turn in early, so the blends start 1.5 m after a gate;
    # the CoG must be across before the front corners (lead_m ahead of it) reach the next gate
    return jnp.where(
        x < b0 - lead_m,
        blend(x, a1 + 1.5, b0 - lead_m, y1, y3),
        blend(x, b1 + 1.5, c0 - lead_m, y3, y5),
    )


def _footprint_margin(course: Course, vehicle: Vehicle, px: Array, py: Array, psi: Array) -> Array:
    """Smallest signed distance [m] of the body corners to the gated lanes (> 0 inside)."""
    front = vehicle.cog_to_front_axle_m + 0.85  # overhangs of a compact car [m]
    rear = vehicle.cog_to_rear_axle_m + 0.8
    half = 0.5 * course.vehicle_width_m
    lx = jnp.array([front, front, -rear, -rear])
    ly = jnp.array([half, -half, half, -half])
    cx = px + lx * jnp.cos(psi) - ly * jnp.sin(psi)
    cy = py + lx * jnp.sin(psi) + ly * jnp.cos(psi)
    margin = jnp.asarray(10.0)
    for x0, x1, yr, yl in course.lane_bounds:
        inside_x = (cx >= x0) & (cx <= x1)
        d = jnp.minimum(cy - yr, yl - cy)
        margin = jnp.minimum(margin, jnp.min(jnp.where(inside_x, d, 10.0)))
    return margin


def simulate(
    vehicle: Vehicle,
    tyres: Tyres | AxleTyres,
    speed_mps: Float[ArrayLike, ""],
    course: Course,
    driver: Driver = DEFAULT_DRIVER,
    n_steps: int = 500,
) -> tuple[Float[Array, ""], Float[Array, "n"], Float[Array, "n"]]:
    """Closed-loop run through the course from entry speed ``speed_mps`` (throttle released).

    Fixed-step semi-implicit Euler in ``jax.lax.scan``; the step is dt = 1.15·L/(n·v) so every run
    covers the course (L = 61 m) plus margin with the same number of steps (no recompilation).

    Returns
    -------
    (margin_m, x_m, y_m)
        Minimum corner-to-boundary distance over the run [m] (> 0: no cone struck) and the CoG path.
    """
    v0 = jnp.asarray(speed_mps, dtype=float)
    length = course.x_edges_m[-1]
    dt = 1.15 * (length + 5.0) / (n_steps * v0)
    m, lf, lr = vehicle.mass_kg, vehicle.cog_to_front_axle_m, vehicle.cog_to_rear_axle_m
    wb, h, tw = vehicle.wheelbase_m, vehicle.cog_height_m, vehicle.track_width_m
    fz_f, fz_r = static_axle_loads(vehicle)
    c_f, c_r, mu = (
        jnp.asarray(tyres.c_y_front),
        jnp.asarray(tyres.c_y_rear),
        jnp.asarray(tyres.mu_y),
    )
    k = tyres.load_sensitivity
    lead = lf + 0.85
    y_start = _centre_path(course, jnp.asarray(0.0), lead)

    def axle_force(alpha: Array, c_y: Array, fz_axle: float, share: float, ay: Array) -> Array:
        # lateral load transfer m a_y h / t, shared by the axles like the static load; c_y is
        # per unit load, so the axle's slope at α = 0 is c_y · fz_axle whatever the transfer
        d = m * ay * h / tw * share
        fz_in, fz_out = jnp.maximum(fz_axle / 2 - d, 0.0), fz_axle / 2 + d
        mu_in = mu * (1.0 - k * (fz_in / (fz_axle / 2) - 1.0))
        mu_out = mu * (1.0 - k * (fz_out / (fz_axle / 2) - 1.0))
        return fz_in * brush_lateral(alpha, c_y, mu_in) + fz_out * brush_lateral(alpha, c_y, mu_out)

    def step(carry: tuple, _: None) -> tuple:
        px, py, psi, vx, vy, r, steer, cmd, ay, margin = carry
        # driver: pure pursuit on the preview point, lagged by the reaction time
        look = jnp.maximum(driver.preview_s * vx, 2.0)
        tx = px + look * jnp.cos(psi)
        ey = _centre_path(course, tx, lead) - (py + look * jnp.sin(psi))
        target = jnp.arctan(2.0 * wb * ey / look**2)
        target = jnp.clip(target, -driver.max_steer_rad, driver.max_steer_rad)
        cmd = cmd + dt / (driver.reaction_s + dt) * (target - cmd)
        rate = jnp.clip(
            (cmd - steer) / dt, -driver.max_steer_rate_radps, driver.max_steer_rate_radps
        )
        steer = steer + rate * dt
        # tyres
        alpha_f = steer - (vy + lf * r) / vx
        alpha_r = -(vy - lr * r) / vx
        fy_f = axle_force(alpha_f, c_f, fz_f, lr / wb, ay)
        fy_r = axle_force(alpha_r, c_r, fz_r, lf / wb, ay)
        resist = aero_drag(vehicle, vx) + rolling_resistance_force(vehicle)
        fx_f, fx_r = -resist * lr / wb, -resist * lf / wb
        c, s = jnp.cos(steer), jnp.sin(steer)
        ax = (fx_r + fx_f * c - fy_f * s) / m
        ay_new = (fy_r + fx_f * s + fy_f * c) / m
        yaw_acc = (lf * (fy_f * c + fx_f * s) - lr * fy_r) / vehicle.yaw_inertia_kgm2
        vx = jnp.maximum(vx + (ax + r * vy) * dt, 1.0)
        vy = vy + (ay_new - r * vx) * dt
        r = r + yaw_acc * dt
        psi = psi + r * dt
        px = px + (vx * jnp.cos(psi) - vy * jnp.sin(psi)) * dt
        py = py + (vx * jnp.sin(psi) + vy * jnp.cos(psi)) * dt
        margin = jnp.minimum(margin, _footprint_margin(course, vehicle, px, py, psi))
        return (px, py, psi, vx, vy, r, steer, cmd, ay_new, margin), (px, py)

    zero = jnp.zeros_like(v0)
    init = (zero - 2.0, zero + y_start, zero, v0, zero, zero, zero, zero, zero, zero + 10.0)
    final, (xs, ys) = jax.lax.scan(step, init, None, length=n_steps)
    # a run that never leaves the course end (spin, stall) also fails
    reached = final[0] >= length
    return jnp.where(reached, final[-1], jnp.minimum(final[-1], -0.01)), xs, ys


def run_margin(
    vehicle: Vehicle,
    tyres: Tyres | AxleTyres,
    speed_mps: Float[ArrayLike, ""],
    course: Course,
    driver: Driver = DEFAULT_DRIVER,
    n_steps: int = 500,
) -> Float[Array, ""]:
    """Minimum footprint margin [m] of one run (> 0 passes). Differentiable almost everywhere."""
    return simulate(vehicle, tyres, speed_mps, course, driver, n_steps)[0]


#: The critical-speed search range [m/s] (29-162 km/h). Below 8 m/s the coasting car does not
#: reach the course's end in the simulation's fixed step count, so every run fails there.
SEARCH_RANGE_MPS = (8.0, 45.0)


class CriticalSpeed(eqx.Module):
    """Result of :func:`critical_speed`: speeds [m/s], flags as data.

    ``below_range``: the run failed at the range's lower end (V_max is below it, or cannot be
    resolved there); ``above_range``: it passed at the upper end (V_max is above it).
    """

    v_max_mps: Float[Array, ""]  # highest speed shown to pass (lower bracket end)
    v_fail_mps: Float[Array, ""]  # lowest speed shown to fail (upper bracket end)
    bracketed: Bool[Array, ""]  # lower end passed and upper end failed at the start
    below_range: Bool[Array, ""]
    above_range: Bool[Array, ""]


def critical_speed(
    vehicle: Vehicle,
    tyres: Tyres | AxleTyres,
    course: Course | None = None,
    driver: Driver = DEFAULT_DRIVER,
    v_lo_mps: float = SEARCH_RANGE_MPS[0],
    v_hi_mps: float = SEARCH_RANGE_MPS[1],
    tol_mps: float = 0.05,
    n_steps: int = 500,
) -> CriticalSpeed:
    """Critical entry speed V_max by bisection on pass/fail; final bracket width ≤ ``tol_mps``.

    Iteration count ⌈log2((v_hi − v_lo)/tol)⌉ is static, so this jits and vmaps over ``tyres``.

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> cs = critical_speed(load_vehicle("compact_fwd"), Tyres(20.0, 1.0), tol_mps=1.0)
    >>> bool(cs.v_fail_mps - cs.v_max_mps <= 1.0)
    True
    """
    if not tol_mps > 0:
        raise ValueError(f"tol_mps must be > 0, got {tol_mps}")
    course = iso3888_2_course(vehicle.width_m) if course is None else course
    n_iter = max(1, math.ceil(math.log2((v_hi_mps - v_lo_mps) / tol_mps)))

    def passes(v: Array) -> Array:
        return run_margin(vehicle, tyres, v, course, driver, n_steps) > 0.0

    lo, hi = jnp.asarray(v_lo_mps), jnp.asarray(v_hi_mps)
    below, above = ~passes(lo), passes(hi)

    def body(_: Array, bounds: tuple[Array, Array]) -> tuple[Array, Array]:
        a, b = bounds
        mid = 0.5 * (a + b)
        ok = passes(mid)
        return jnp.where(ok, mid, a), jnp.where(ok, b, mid)

    a, b = jax.lax.fori_loop(0, n_iter, body, (lo, hi))
    return CriticalSpeed(a, b, ~below & ~above, below, above)


def critical_speed_sensitivity(
    vehicle: Vehicle,
    tyres: Tyres,
    course: Course | None = None,
    driver: Driver = DEFAULT_DRIVER,
    tol_mps: float = 0.05,
    n_steps: int = 500,
) -> dict[str, Float[Array, ""]]:
    """dV_max/dC_y and dV_max/dμ_y [m/s per unit] by implicit differentiation of margin(V, θ) = 0.

    At the critical speed the footprint margin crosses zero, so dV/dθ = −(∂m/∂θ)/(∂m/∂V), both
    partials by ``jax.grad`` through the scan at the bisection's bracket midpoint. The margin is a
    min over time and corners, hence piecewise smooth: the result is the derivative of the active
    constraint (the cone that falls first); near a switch of active cone it jumps.
    """
    course = iso3888_2_course(vehicle.width_m) if course is None else course
    cs = critical_speed(vehicle, tyres, course, driver, tol_mps=tol_mps, n_steps=n_steps)
    v = 0.5 * (cs.v_max_mps + cs.v_fail_mps)

    def margin(v_: Array, c_y: Array, mu: Array) -> Array:
        t = Tyres(c_y, mu, tyres.load_sensitivity)
        return run_margin(vehicle, t, v_, course, driver, n_steps)

    dm_dv, dm_dc, dm_dmu = jax.grad(margin, argnums=(0, 1, 2))(
        v, jnp.asarray(tyres.c_y, dtype=float), jnp.asarray(tyres.mu_y, dtype=float)
    )
    return {"v_mps": v, "dv_dc_y": -dm_dc / dm_dv, "dv_dmu_y": -dm_dmu / dm_dv}
