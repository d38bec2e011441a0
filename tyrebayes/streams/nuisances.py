"""Sensor nuisances estimated from the stream, so inference can treat them as parameters.

Per-wheel rolling radii differ by fractions of a percent (the size of the slip signal), the IMU
has a bias and a mounting pitch, roads have grade, and a GNSS reference fixes the absolute scale
of the wheel radius. None of these is hidden inside the features: each is estimated here with a
standard error, and :class:`StreamNuisances` carries the numbers.

Examples
--------
>>> import numpy as np
>>> dv = np.zeros(1000); ax = dv + 0.3
>>> round(estimate_ax_offset(ax, dv, np.ones(1000, bool), 100.0)[0], 3)
0.3
"""

from __future__ import annotations

import equinox as eqx
import numpy as np
from jaxtyping import Bool, Float

# Effective number of independent samples: grade and vibration are correlated over about a
# second, so a standard error from N samples at 100 Hz divides by sqrt(seconds), not sqrt(N).
_CORRELATION_S = 1.0


class StreamNuisances(eqx.Module):
    """Nuisance quantities of one stream with their standard errors.

    Attributes
    ----------
    radius_ratio : ndarray, shape (4,)
        Rolling radius of each wheel (fl, fr, rl, rr) over the mean of the four, from straight
        free rolling; NaN if there was too little free rolling. Multiplying a wheel's speed by
        its ratio removes its static slip offset.
    radius_ratio_sd : ndarray, shape (4,)
        Standard errors of ``radius_ratio``.
    radius_ratio_seconds : float
        Seconds of straight free rolling behind the estimate.
    ax_offset_mps2 : float
        IMU longitudinal offset: bias + g sin(mounting pitch) + g sin(mean road grade of the
        log) [m/s²], from ax − dV_x/dt. Subtracted from ax before the force balance.
    ax_offset_sd_mps2 : float
        Its standard error [m/s²], including the uncertainty of the log's mean grade (which one
        log cannot separate from the mounting pitch; several logs of one car can).
    pitch_offset_rad : float
        The offset read as a mounting pitch, asin(offset / g) [rad].
    ay_offset_mps2 : float
        IMU lateral offset (bias + g sin(mounting roll) + mean road camber), from ay − V_x ψ̇.
    quantisation_radps : ndarray, shape (4,)
        Wheel-speed quantisation steps found in the raw data [rad/s] (0 = continuous).
    speed_scale : float
        Median V_x / speed_reference: the true rolling radius of the V_x wheels over the nominal
        radius is 1 / speed_scale. NaN without a reference.
    speed_scale_sd : float
        Its standard error.
    rho_offset_sd : float
        The ax offset's error as an error of ρ_x of the driven axle: one offset shared by every
        sample of the log (a per-log nuisance parameter for the inference, not per-sample noise).
    smoothed_noise : dict
        Noise sd at the smoothing scale, measured with the vehicle motion removed: ``vx_mps``,
        ``slip_velocity_mps`` (per wheel, R·Ω − V_x), ``slip_velocity_driven_mps``, ``ax_mps2``.
        The per-sample ``*_sd`` arrays of :class:`StreamFeatures` are built from these.
    """

    radius_ratio: Float[np.ndarray, "4"]
    radius_ratio_sd: Float[np.ndarray, "4"]
    radius_ratio_seconds: float
    ax_offset_mps2: float
    ax_offset_sd_mps2: float
    pitch_offset_rad: float
    ay_offset_mps2: float
    quantisation_radps: Float[np.ndarray, "4"]
    speed_scale: float
    speed_scale_sd: float
    rho_offset_sd: float
    smoothed_noise: dict = eqx.field(static=True)


def _robust_mean_se(x: np.ndarray, sample_rate_hz: float) -> tuple[float, float]:
    """Median and its standard error with a one-second correlation time."""
    if x.size < 3:
        return float("nan"), float("nan")
    med = float(np.median(x))
    spread = 1.4826 * float(np.median(np.abs(x - med)))
    n_eff = max(x.size / (sample_rate_hz * _CORRELATION_S), 1.0)
    return med, 1.2533 * spread / np.sqrt(n_eff)  # 1.2533: efficiency of the median


def estimate_ax_offset(
    ax_mps2: Float[np.ndarray, "n"],
    dvx_dt_mps2: Float[np.ndarray, "n"],
    use: Bool[np.ndarray, "n"],
    sample_rate_hz: float,
) -> tuple[float, float]:
    """IMU longitudinal offset: median of ax − dV_x/dt over the usable samples [m/s²].

    The accelerometer measures dV_x/dt + g sin(grade + mounting pitch) + bias. Over a log the
    constant part is the mounting pitch plus bias plus the mean grade; the varying rest is the
    road grade, which the force balance needs and keeps.

    Returns
    -------
    (offset, standard error) [m/s²]
    """
    diff = ax_mps2 - dvx_dt_mps2
    ok = use & np.isfinite(diff)
    return _robust_mean_se(diff[ok], sample_rate_hz)


# Road grade decorrelates over roughly a kilometre (~60 s of driving): a log of T seconds holds
# about T / 60 independent grade values for its mean.
_GRADE_CORRELATION_S = 60.0


def mean_grade_sd(grade_rad: Float[np.ndarray, "n"], sample_rate_hz: float) -> float:
    """Uncertainty of a log's mean road grade from the spread of its grade estimate [rad].

    sd(grade) / sqrt(max(T / 60 s, 1)); 0 if the grade cannot be estimated.
    """
    g = grade_rad[np.isfinite(grade_rad)]
    if g.size < 3:
        return 0.0
    seconds = g.size / sample_rate_hz
    return float(np.std(g) / np.sqrt(max(seconds / _GRADE_CORRELATION_S, 1.0)))


def estimate_radius_ratios(
    wheel_vx_mps: Float[np.ndarray, "n 4"],
    free_straight: Bool[np.ndarray, "n"],
    sample_rate_hz: float,
    min_seconds: float = 2.0,
) -> tuple[Float[np.ndarray, "4"], Float[np.ndarray, "4"], float]:
    """Per-wheel rolling radius over the four-wheel mean, from straight free rolling.

    In free rolling every tyre carries (almost) no longitudinal force, so its slip is (almost)
    zero and its speed ratio to the others is its radius ratio.

    Parameters
    ----------
    wheel_vx_mps : ndarray, shape (n, 4)
        Each wheel's speed with the nominal radius, translated to the vehicle's V_x (curve
        compensated) [m/s].
    free_straight : ndarray of bool, shape (n,)
        Straight free-rolling samples.
    min_seconds : float
        Less free rolling than this gives NaN (too few to beat the quantisation).

    Returns
    -------
    (ratio, sd, seconds)
    """
    ok = free_straight & np.all(np.isfinite(wheel_vx_mps), axis=1)
    seconds = float(ok.sum() / sample_rate_hz)
    nan4 = np.full(4, np.nan)
    if seconds < min_seconds:
        return nan4, nan4.copy(), seconds
    sub = wheel_vx_mps[ok]
    # A larger radius turns slower at the same ground speed: radius ratio = mean speed / speed.
    rel = np.mean(sub, axis=1, keepdims=True) / sub
    ratio, sd = np.empty(4), np.empty(4)
    for i in range(4):
        ratio[i], sd[i] = _robust_mean_se(rel[:, i], sample_rate_hz)
    return ratio, sd, seconds


def estimate_speed_scale(
    vx_mps: Float[np.ndarray, "n"],
    reference_mps: Float[np.ndarray, "n"],
    use: Bool[np.ndarray, "n"],
    sample_rate_hz: float,
) -> tuple[float, float]:
    """Median V_x / speed_reference over moving samples, with its standard error."""
    ok = use & np.isfinite(vx_mps) & np.isfinite(reference_mps) & (reference_mps > 3.0)
    return _robust_mean_se(vx_mps[ok] / reference_mps[ok], sample_rate_hz)
