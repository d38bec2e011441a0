"""Step 2 of the signal pipeline: the wheel signals' noise at the smoothing scale, measured on
probes with the vehicle motion removed (slip velocities, differences of the V_x wheels).

Called by :func:`tyrebayes.streams.features.compute_features`.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np
from jaxtyping import Float

from .filters import PrefixSums, nan_moving_average
from .motion import _NON_DRIVEN, _Motion, _row_mean, _Scales, _table, _vehicle_speed, _wheel_to_vx
from .noise import local_noise_sd


def _slip_noise_probe(
    slip_velocity: np.ndarray,
    slip_velocity_sums: PrefixSums,
    force_velocity: np.ndarray,
    pushing: np.ndarray,
    window: int,
) -> np.ndarray:
    """The driven axle's slip velocity R·Ω − V_x less the part that follows the force.

    The slip velocity σV_x moves with the force over 0.2-1 s, the scale at which its noise is
    measured, so taken as it is its real changes count as noise (several times the noise on
    drives with brisk acceleration changes: a test with a noise-free 0.7 Hz ripple). Here the
    part of it that the force explains linearly, b·ρV_x, is taken off first, with b (≈ 1/C_x)
    from a least-squares fit over the drive of the two signals high-passed like
    :func:`~tyrebayes.streams.noise.local_noise_sd` does; what is left is sensor noise and what
    the linear fit misses. Only where the tyres push: under braking the reference wheels brake
    too and the relation is another (NaN there; the caller takes the plain slip velocity's
    noise where no pushing sample is near). ``slip_velocity_sums`` are the slip velocity's
    :class:`~tyrebayes.streams.filters.PrefixSums`, which the caller's noise estimate of the
    same signal reads too.
    """
    half = (5 * window) // 2  # nan_moving_average's half-window for 5 * window samples
    s = slip_velocity - slip_velocity_sums.window_mean(half)
    r = force_velocity - nan_moving_average(force_velocity, 5 * window)
    ok = np.isfinite(s) & np.isfinite(r) & pushing
    r_ok = r[ok]
    denominator = float(np.sum(r_ok**2))
    slope = float(np.sum(s[ok] * r_ok)) / denominator if denominator > 0 else 0.0
    return np.where(pushing, slip_velocity - slope * force_velocity, np.nan)


def _vx_noise_probe(wheel_vx: np.ndarray, drive: str) -> np.ndarray:
    """A zero-mean combination of the V_x wheels with the noise of their mean (motion cancels)."""
    if drive == "awd":
        return 0.25 * (wheel_vx[:, 0] - wheel_vx[:, 1] + wheel_vx[:, 2] - wheel_vx[:, 3])
    a, b = _NON_DRIVEN[drive]
    return 0.5 * (wheel_vx[:, a] - wheel_vx[:, b])


class _WheelNoise(eqx.Module):
    """Step 2: the wheel signals' noise at the smoothing scale, with the vehicle motion removed."""

    slip_velocity_driven: Float[np.ndarray, "n"]  # driven axle's R·Ω − V_x, unsmoothed [m/s]
    local_wheel: Float[np.ndarray, "n 4"]  # each wheel's slip-velocity noise [m/s]
    slip_sd: Float[np.ndarray, "n 4"]  # [-]
    vx_sd: Float[np.ndarray, "n"]  # [m/s]
    # Prefix sums of the V_x wheels' zero-mean combination (_vx_noise_probe): the noise of
    # the wheel speeds' dV_x/dt (_traction_acceleration) is measured on it too.
    vx_probe: PrefixSums


def _wheel_noise(motion: _Motion, vehicle, scales: _Scales, spin_threshold) -> _WheelNoise:
    # Noise at the smoothing scale, measured on signals with the vehicle motion removed (slip
    # velocities R·Ω − V_x, differences of the V_x wheels), per sample over ~10 s: coloured noise,
    # quantisation and changing road roughness included, unlike a white-noise / √window rule.
    # The probes use the unsmoothed wheel speeds: local_noise_sd applies the smoothing itself.
    m = motion
    # The four slip velocities and the V_x probe in one column-contiguous block: the wheels'
    # V_x are written into it and turned into slip velocities in place.
    probes = np.empty((5, m.vx.shape[0])).T
    wheel_vx_raw = _wheel_to_vx(m.omega_raw, m.yaw, vehicle, m.trig, out=probes[:, :4])
    vx_raw = np.where(
        m.valid, _vehicle_speed(wheel_vx_raw, vehicle.drive, spin_threshold)[0], np.nan
    )
    probes[:, 4] = _vx_noise_probe(wheel_vx_raw, vehicle.drive)
    for i in range(4):
        probes[:, i] -= vx_raw
    slip_velocity_driven = _row_mean(probes, m.driven_wheels)
    vx_probe = PrefixSums.of(probes[:, 4])
    # The slip velocities are NaN where V_x is (not valid): V_x's counts serve them.
    probe_sd = local_noise_sd(
        probes, scales.window, scales.span, like=m.vx_prefix, prefix=(None,) * 4 + (vx_probe,)
    )
    local_wheel = probe_sd[:, :4]
    return _WheelNoise(
        slip_velocity_driven=slip_velocity_driven,
        local_wheel=local_wheel,
        slip_sd=np.divide(local_wheel, m.vx_safe[:, None], out=_table(*local_wheel.shape)),
        vx_sd=probe_sd[:, 4],
        vx_probe=vx_probe,
    )
