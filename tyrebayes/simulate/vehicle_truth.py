"""The car actually driven is not exactly the car in its vehicle file.

The pipeline computes ρ_x = F_x / F_z from the vehicle file, so whatever the file gets wrong in
the *ratio* of force to load is a force gain the tyre model has to carry (its ``force_gain``).
The mass cancels from that ratio (F_x = m a_x and F_z ∝ m g, up to drag), but where the mass sits
does not: passengers and luggage move the static front load share, the centre of gravity's
height sets the load transfer, and the suspension's pitch gradient sets how much the IMU
over-reads a_x (:func:`tyrebayes.physics.vehicle.body_pitch_gain`). The IMU's own scale-factor
error is a sensor offset (:attr:`~tyrebayes.simulate.sensors.SensorModel.ax_gain_sd`).

:func:`draw_true_vehicle` draws such a car around a vehicle file, so that a recovery benchmark
tests the model in the world its priors describe (simulation-based calibration), not in one
where the vehicle file is exact.

Examples
--------
>>> import numpy as np
>>> from tyrebayes._domain import load_vehicle
>>> nominal = load_vehicle("compact_fwd")
>>> car = draw_true_vehicle(np.random.default_rng(0), nominal, VehicleSpread())
>>> car.mass_kg == nominal.mass_kg, car.cog_to_front_axle_m != nominal.cog_to_front_axle_m
(True, True)
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import numpy as np

from ..physics.thermal import ThermalParams
from ..physics.vehicle import Vehicle, axle_loads, body_pitch_gain


def _check_spreads(spread: eqx.Module, upper: float) -> None:
    """Raise ValueError unless every field of ``spread`` is finite and in [0, upper)."""
    for field in dataclasses.fields(spread):
        value = getattr(spread, field.name)
        if not (np.isfinite(value) and 0.0 <= value < upper):
            raise ValueError(
                f"{type(spread).__name__}.{field.name}: expected a value in [0, {upper}), "
                f"got {value}"
            )


class VehicleSpread(eqx.Module):
    """Drive-to-drive spread of the real car around its vehicle file.

    Parameters
    ----------
    front_load_share_sd : float
        Sd of the static front-axle load share (absolute) [-]. Two rear passengers (150 kg at
        55 % of the wheelbase behind the front axle) move the compact's 62 % front share to
        60.5 %: 0.012, i.e. ±2 % of the front load (an assumption of that size).
    cog_height_rel_sd : float
        Relative sd of the centre-of-gravity height [-] (load, roof box): 0.05.
    pitch_gradient_rel_sd : float
        Relative sd of the body pitch gradient [-]: 0.25 around the vehicle file's value, an
        assumption (suspension tuning and load differ from car to car).

    Together with an IMU scale-factor error of 1 % these give the driven axle's ρ_x a gain
    error (:func:`force_gain`) with a log-sd of 0.023 on the front-driven compact at small a_x
    (4,000 draws); the CoG height adds a load-transfer error that grows with |a_x|.
    """

    front_load_share_sd: float = 0.012
    cog_height_rel_sd: float = 0.05
    pitch_gradient_rel_sd: float = 0.25

    def __check_init__(self):
        _check_spreads(self, 0.5)


def draw_true_vehicle(rng: np.random.Generator, vehicle: Vehicle, spread: VehicleSpread) -> Vehicle:
    """The car actually driven: ``vehicle`` with its load share, CoG height and pitch redrawn.

    Parameters
    ----------
    rng : numpy.random.Generator
        Random source.
    vehicle : Vehicle
        The vehicle file (what the pipeline will assume).
    spread : VehicleSpread
        How far the real car may be from it.

    Returns
    -------
    Vehicle
        Same mass, geometry and drive; l_f, h and k drawn (each truncated to stay physical).
    """
    z = rng.standard_normal(3)
    wheelbase = float(vehicle.wheelbase_m)
    front_share = 1.0 - float(vehicle.cog_to_front_axle_m) / wheelbase
    front_share = float(np.clip(front_share + spread.front_load_share_sd * z[0], 0.3, 0.8))
    return dataclasses.replace(
        vehicle,
        cog_to_front_axle_m=(1.0 - front_share) * wheelbase,
        cog_height_m=float(vehicle.cog_height_m) * float(np.exp(spread.cog_height_rel_sd * z[1])),
        pitch_gradient_rad_per_mps2=float(vehicle.pitch_gradient_rad_per_mps2)
        * float(np.exp(spread.pitch_gradient_rel_sd * z[2])),
    )


class ThermalSpread(eqx.Module):
    """Spread of a real tyre's heat balance around the nominal :class:`ThermalParams`.

    The pipeline estimates tyre temperature with the nominal parameters
    (:mod:`tyrebayes.streams.tyre_temperature`); a simulated drive whose tyres heat exactly that
    way would test the estimate in a world it cannot miss. Relative (log-scale) sds, assumptions
    of the size of the spread between tyre sizes and label classes:

    Parameters
    ----------
    rolling_resistance_rel_sd : float
        EU label classes C-E span f_rr 0.0075-0.0105 around 0.010: 0.15.
    heat_capacity_rel_sd : float
        Tyre mass 7-11 kg for the same car: 0.2.
    convection_rel_sd : float
        Wheel-arch flow and rim differ from car to car: 0.2 on both convection coefficients.
    """

    rolling_resistance_rel_sd: float = 0.15
    heat_capacity_rel_sd: float = 0.2
    convection_rel_sd: float = 0.2

    def __check_init__(self):
        _check_spreads(self, 1.0)


def draw_true_thermal(
    rng: np.random.Generator, spread: ThermalSpread, nominal: ThermalParams | None = None
) -> ThermalParams:
    """The heat balance of the tyres actually driven: ``nominal`` with its coefficients redrawn.

    Examples
    --------
    >>> p = draw_true_thermal(np.random.default_rng(0), ThermalSpread())
    >>> p.rolling_resistance != ThermalParams().rolling_resistance
    True
    """
    nominal = ThermalParams() if nominal is None else nominal
    z = rng.standard_normal(3)
    return ThermalParams(
        rolling_resistance=float(nominal.rolling_resistance)
        * float(np.exp(spread.rolling_resistance_rel_sd * z[0])),
        heat_capacity_j_per_k=float(nominal.heat_capacity_j_per_k)
        * float(np.exp(spread.heat_capacity_rel_sd * z[1])),
        convection_still_w_per_k=float(nominal.convection_still_w_per_k)
        * float(np.exp(spread.convection_rel_sd * z[2])),
        convection_speed_w_per_k=float(nominal.convection_speed_w_per_k)
        * float(np.exp(spread.convection_rel_sd * z[2])),
        convection_speed_exponent=nominal.convection_speed_exponent,
        friction_heat_fraction=nominal.friction_heat_fraction,
    )


def force_gain(true_vehicle: Vehicle, vehicle: Vehicle, ax_gain: float = 1.0) -> float:
    """Gain of the driven axle's ρ_x computed from ``vehicle`` over that of ``true_vehicle`` [-].

    The measured over the true ρ_x at small a_x: the IMU's scale factor and the true-over-assumed
    pitch gain scale the force; the load is divided by the assumed instead of the true static
    load of the driven axle(s).

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> car = load_vehicle("compact_fwd")
    >>> force_gain(car, car, ax_gain=1.01)
    1.01
    """
    pitch = float(body_pitch_gain(true_vehicle)) / float(body_pitch_gain(vehicle))

    def driven_static_load(v: Vehicle) -> float:
        front, rear = (float(x) for x in axle_loads(v, 0.0))
        return {"front": front, "rear": rear, "both": front + rear}[v.driven_axle]

    load = driven_static_load(true_vehicle) / driven_static_load(vehicle)
    return float(ax_gain * pitch * load)
