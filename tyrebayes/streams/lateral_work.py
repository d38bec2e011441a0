"""Lateral friction work of one drive per axle (thesis eq. 4.19b, 4.23b, c).

* **Lateral friction work** per axle, W_y = ∫ F_y V_x tan α dt (eq. 4.19b) with the axle forces of
  the single-track model (eq. 4.23b, c, from a_y and yaw acceleration; Newton's law holds in
  transients too, so every valid sample counts) and the slip angle of a brush tyre,
  tan α = 3 ρ_y / (c_y (1 + a + a²)), a = (1 − |ρ_y| / μ)^⅓ (the linear α = ρ_y / c_y for
  small ρ_y), with the per-axle cornering stiffness c_y of :class:`CorneringStiffness`: an
  inferred axle stiffness where a lateral posterior exists
  (:func:`tyrebayes.inference.wear.cornering_stiffness_from_lateral`), otherwise the type prior
  :data:`TYPE_PRIOR_CORNERING` (yaw rate and lateral acceleration fix F_y, not the split of
  δ − L ψ̇ / V between the axles' slip angles). W_y scales as 1 / c_y: the stiffness' log-sd is
  carried with the evidence, and the wear fit treats it as the lateral work's scale error.
"""

from __future__ import annotations

import numpy as np

from ..physics.vehicle import Vehicle
from .features import StreamFeatures

#: Friction coefficient of the brush slip angle [-]: the dry-road median of the package's μ prior
#: (:data:`tyrebayes.inference.surface_friction.MU_MEDIAN`); it only bends α where |ρ_y| nears μ.
LATERAL_MU = 1.0


def brush_slip_angle(rho_y: np.ndarray, c_y_per_rad, mu: float = LATERAL_MU) -> np.ndarray:
    """tan α of a brush tyre at normalised lateral force ρ_y = F_y / F_z (module docstring).

    ``c_y_per_rad`` broadcasts against ``rho_y`` (e.g. shape (2,) for (n, 2) axle forces);
    |ρ_y| is held below 0.97 μ (beyond the peak the slip is not defined by the force).

    Examples
    --------
    >>> t = brush_slip_angle(np.array([0.01, 0.5]), 16.5)
    >>> bool(abs(t[0] / (0.01 / 16.5) - 1) < 0.01), bool(t[1] > 0.5 / 16.5)
    (True, True)
    """
    rho = np.clip(np.asarray(rho_y, dtype=float), -0.97 * mu, 0.97 * mu)
    a = np.cbrt(1.0 - np.abs(rho) / mu)
    return 3.0 * rho / (np.asarray(c_y_per_rad, dtype=float) * (1.0 + a + a * a))


def lateral_power(
    feats: StreamFeatures, vehicle: Vehicle, valid: np.ndarray, c_y_per_rad: np.ndarray
) -> np.ndarray:
    """Lateral friction power of each axle per sample, shape (n, 2) [W] (0 where unusable).

    The axle forces are the single-track model's (eq. 4.23b, c) from a_y = V_x ψ̇ and the yaw
    acceleration; the slip angle the brush tyre's at each axle's ``c_y_per_rad`` (shape (2,)).
    Summed over the samples times the sample interval it is each axle's lateral friction work.

    Examples
    --------
    >>> from tyrebayes import load_vehicle, read_stream, validate_stream, compute_features
    >>> from tyrebayes._resources import data_dir
    >>> vehicle = load_vehicle("suv_rav4")
    >>> stream = validate_stream(read_stream(data_dir() / "comma2k19_rav4_segment.csv"), vehicle)
    >>> feats = compute_features(stream, vehicle)
    >>> power = lateral_power(feats, vehicle, feats.valid, np.array([16.5, 16.5]))
    >>> power.shape == (feats.vx_mps.size, 2), bool(np.all(power >= 0))
    (True, True)
    """
    vx = feats.vx_mps
    fz = feats.fz_axle_n
    # a_y = V_x ψ̇ (quasi-steady: v̇_y neglected): the gyro's noise is a small fraction of the
    # accelerometer's, and noise squared in ρ_y² would read as lateral work on straight roads
    ay = vx * feats.yaw_rate_radps
    yaw_acc = feats.yaw_acc_radps2
    usable_y = valid & np.isfinite(ay) & np.isfinite(yaw_acc)
    lf, lr = vehicle.cog_to_front_axle_m, vehicle.wheelbase_m - vehicle.cog_to_front_axle_m
    fy_front = (
        vehicle.mass_kg * ay * lr + vehicle.yaw_inertia_kgm2 * yaw_acc
    ) / vehicle.wheelbase_m
    fy_rear = (vehicle.mass_kg * ay * lf - vehicle.yaw_inertia_kgm2 * yaw_acc) / vehicle.wheelbase_m
    fy = np.column_stack([fy_front, fy_rear])
    with np.errstate(invalid="ignore", divide="ignore"):
        tan_alpha = brush_slip_angle(fy / fz, np.asarray(c_y_per_rad)[None, :])
        power_y = np.abs(fy * vx[:, None] * tan_alpha)
    ok_y = usable_y[:, None] & np.isfinite(power_y)
    return np.where(ok_y, power_y, 0.0)
