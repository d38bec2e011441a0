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

from .filters import PrefixSums
from .order_stats import median

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
    ax_gain : ImuGainCorrection
        The IMU's longitudinal scale factor against the wheel-speed derivative, and whether ax
        was divided by it (:func:`imu_gain_correction`).
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
    ax_gain: ImuGainCorrection
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
    med = median(x)
    spread = 1.4826 * median(np.abs(x - med))
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


# Blocks for the gain's standard error: the residual stays correlated over seconds.
_GAIN_BLOCK_S = 5.0
# Grade varies over hundreds of metres and correlates with acceleration (cars slow uphill), which
# biases a plain slope: 0.745 for a true 0.8 on a simulated 600 s drive. Both signals are
# high-passed by removing their 20 s moving average (0.790 there; 0.797 with the low-pass below
# too); the driver's accelerations, lasting seconds, pass.
_GAIN_HIGHPASS_S = 20.0
# dV_x/dt from the wheel speeds is noisy at short scales, and a slope on a noisy regressor is
# attenuated (errors in variables): with twice the default sensor noise, 0.5 s smoothing read a
# calibrated IMU at 0.94-0.95 on two 20-minute drives, 2 s smoothing at 0.98-0.99 (and the
# tyre fits' C_x came out 3 % high through it). So both signals are low-passed over 2 s too.
_GAIN_LOWPASS_S = 2.0


def estimate_ax_gain(
    ax_mps2: Float[np.ndarray, "n"],
    dvx_dt_mps2: Float[np.ndarray, "n"],
    use: Bool[np.ndarray, "n"],
    sample_rate_hz: float,
) -> tuple[float, float]:
    """IMU longitudinal scale factor: slope of ax on dV_x/dt from the wheel speeds [-].

    The wheel speeds give dV_x/dt on an absolute scale (the rolling radius is known to a fraction
    of a percent); the accelerometer reads k (dV_x/dt + g sin grade) + bias. Both are
    band-passed (their 2 s moving average less their 20 s one), which takes out the bias, most
    of the grade and the derivative's short-scale noise (which would attenuate the slope), and
    the least-squares slope of one on the other is k. The standard error is a block
    sandwich over 5 s blocks, since the residual (the rest of the grade, the smoothed noise) is
    correlated over seconds.

    Returns
    -------
    (gain, standard error); NaN for both when fewer than two blocks or no acceleration spread.

    Examples
    --------
    >>> dv = np.sin(np.linspace(0.0, 60.0, 6000)); ax = 0.8 * dv + 0.1
    >>> round(estimate_ax_gain(ax, dv, np.ones(6000, bool), 100.0)[0], 3)
    0.8
    """
    ok = use & np.isfinite(ax_mps2) & np.isfinite(dvx_dt_mps2)
    short = max(1, int(round(_GAIN_LOWPASS_S * sample_rate_hz)))
    long = max(1, int(round(_GAIN_HIGHPASS_S * sample_rate_hz)))

    def bandpass(v: np.ndarray, like: PrefixSums | None) -> tuple[np.ndarray, PrefixSums]:
        # Both moving averages (an even window is rounded up, as nan_moving_average does) from
        # one set of prefix sums; both signals are NaN outside ``ok``, so they share counts.
        prefix = PrefixSums.of(np.where(ok, v, np.nan), like=like)
        return prefix.window_mean(short // 2) - prefix.window_mean(long // 2), prefix

    x_all, prefix = bandpass(dvx_dt_mps2, None)
    y_all, _ = bandpass(ax_mps2, prefix)
    ok = ok & np.isfinite(x_all) & np.isfinite(y_all)
    block = np.floor(np.flatnonzero(ok) / (_GAIN_BLOCK_S * sample_rate_hz)).astype(int)
    x, y = x_all[ok], y_all[ok]
    # ``block`` is sorted: fewer than two blocks when its first and last agree.
    if x.size < 3 or block[0] == block[-1]:
        return float("nan"), float("nan")
    xc = x - x.mean()
    sxx = float(np.sum(xc**2))
    if not sxx > 0:
        return float("nan"), float("nan")
    gain = float(np.sum(xc * (y - y.mean())) / sxx)
    resid = (y - y.mean()) - gain * xc
    scores = np.bincount(block - block.min(), weights=xc * resid)
    return gain, float(np.sqrt(np.sum(scores**2)) / sxx)


# Scale factor of a longitudinal accelerometer: an automotive IMU is calibrated to about 1 %
# (the spread the simulator draws, SensorModel.ax_gain_sd); an aftermarket or phone-grade one
# need not be (the real RAV4 dashcam of comma2k19 reads a_x at 0.79 of the wheel-speed and GNSS
# derivatives alike, benchmarks/real_vs_sim.py). The prior is a mixture of the two.
IMU_GAIN_SD_CALIBRATED = 0.01
IMU_GAIN_SD_UNCALIBRATED = 0.3
IMU_UNCALIBRATED_PRIOR = 0.05


class ImuGainCorrection(eqx.Module):
    """What the stream pipeline does about the IMU's scale factor (:func:`imu_gain_correction`).

    Attributes
    ----------
    estimate, estimate_sd : float
        Slope of ax on dV_x/dt and its standard error [-] (:func:`estimate_ax_gain`); NaN when
        the log has no accelerations to check it with.
    p_uncalibrated : float
        Posterior probability that the IMU is not calibrated to its nominal scale [-].
    applied : float
        The gain ax is divided by [-]: the posterior mean of the gain beyond a calibrated IMU's
        (whose ~1 % the tyre model's force-gain prior already carries), so 1 for a calibrated
        IMU and about the estimate for a clearly uncalibrated one.
    applied_log_sd : float
        Log-scale uncertainty of ``applied`` beyond a calibrated IMU's [-]: the uncalibrated
        component's posterior spread and the mixture's own. The tyre model widens the drive's
        force-gain prior by it.
    """

    estimate: float
    estimate_sd: float
    p_uncalibrated: float
    applied: float
    applied_log_sd: float

    @property
    def uncalibrated(self) -> bool:
        """The IMU is more probably uncalibrated than calibrated."""
        return self.p_uncalibrated > 0.5


def imu_gain_correction(gain: float, gain_sd: float) -> ImuGainCorrection:
    """The IMU gain to divide ax by, from its estimate under a two-component prior.

    A calibrated IMU has gain 1 ± ``IMU_GAIN_SD_CALIBRATED``, an uncalibrated one
    1 ± ``IMU_GAIN_SD_UNCALIBRATED`` (prior probability ``IMU_UNCALIBRATED_PRIOR``); their
    marginal likelihoods give the posterior probability of each. The applied gain is the
    posterior mean with the calibrated component counted as exactly 1 (the tyre model's force
    gain covers its spread), so the correction is continuous in the estimate: negligible for an
    automotive IMU, about the estimate for a dashcam's, and in between as uncertain as the
    evidence. An estimate without information (NaN) leaves ax as it is.

    Examples
    --------
    >>> round(imu_gain_correction(1.004, 0.003).applied, 4)
    1.0
    >>> round(imu_gain_correction(0.79, 0.02).applied, 2)
    0.79
    """
    if not (np.isfinite(gain) and np.isfinite(gain_sd) and gain_sd > 0):
        return ImuGainCorrection(float(gain), float(gain_sd), IMU_UNCALIBRATED_PRIOR, 1.0, 0.0)

    def log_evidence(prior_sd: float) -> float:
        var = prior_sd**2 + gain_sd**2
        return -0.5 * (gain - 1.0) ** 2 / var - 0.5 * np.log(var)

    log_odds = (
        log_evidence(IMU_GAIN_SD_UNCALIBRATED)
        - log_evidence(IMU_GAIN_SD_CALIBRATED)
        + np.log(IMU_UNCALIBRATED_PRIOR / (1.0 - IMU_UNCALIBRATED_PRIOR))
    )
    p = float(1.0 / (1.0 + np.exp(-np.clip(log_odds, -700.0, 700.0))))
    # The uncalibrated component's posterior: the estimate shrunk towards 1.
    precision = 1.0 / gain_sd**2 + 1.0 / IMU_GAIN_SD_UNCALIBRATED**2
    mean_u = (gain / gain_sd**2 + 1.0 / IMU_GAIN_SD_UNCALIBRATED**2) / precision
    applied = p * mean_u + (1.0 - p)
    variance = p * (1.0 / precision + (mean_u - applied) ** 2) + (1.0 - p) * (1.0 - applied) ** 2
    return ImuGainCorrection(
        float(gain), float(gain_sd), p, float(applied), float(np.sqrt(variance) / applied)
    )


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
    columns = [wheel_vx_mps[:, i] for i in range(4)]
    ok = free_straight.copy()
    for column in columns:
        ok &= np.isfinite(column)
    seconds = float(ok.sum() / sample_rate_hz)
    nan4 = np.full(4, np.nan)
    if seconds < min_seconds:
        return nan4, nan4.copy(), seconds
    sub = [column[ok] for column in columns]
    # A larger radius turns slower at the same ground speed: radius ratio = mean speed / speed.
    mean = ((sub[0] + sub[1]) + sub[2]) + sub[3]  # np.mean's order, column by column
    mean /= 4
    ratio, sd = np.empty(4), np.empty(4)
    for i in range(4):
        ratio[i], sd[i] = _robust_mean_se(mean / sub[i], sample_rate_hz)
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
