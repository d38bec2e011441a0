"""The per-tyre model's prior scales (:class:`TyrePriors`), each with where it comes from.

Re-exported by :mod:`tyrebayes.inference.tyre.model`, whose module docstring gives the model.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp

from ..surface_friction import MU_LOG_SD, MU_MEDIAN

#: Mean and sd of q = d ln C_x / d(ΔF_z/F_z) over the measured car/SUV tyres, rounded
#: (:func:`~tyrebayes.inference.tyre.curve_prior.curve_shape_prior`; a test holds them to it).
MEASURED_LOAD_SENSITIVITY = (0.263, 0.246)


class TyrePriors(eqx.Module):
    """Prior scales of the per-tyre model (reviewed numbers; each says where it comes from).

    Attributes
    ----------
    c_xr_median : float
        Median of C_xr [-]; 35 is mid-range of the thesis' Table 6.2 (29–60).
    c_xr_log_sd : float
        Log-scale sd of C_xr; 0.45 puts 90 % between 17 and 73.
    temp_sensitivity_mean, temp_sensitivity_sd : float
        κ in C_x(T) = C_xr exp(−κ(T − 20)) [1/K]; rubber stiffness falls ~0.5–1 %/K around
        room temperature, so 0.008 ± 0.006.
    load_sensitivity_mean, load_sensitivity_sd : float
        Normal prior of q in C_x ∝ exp(q ΔF_z/F_z,static) [-]. ``load_sensitivity_sd = 0``, the
        default, leaves q out (one C_x at every load); :meth:`with_load_sensitivity` sets the
        mean and widened sd of PKX2/PKX1 + PKX3 over the 9 distinct car/SUV sets of the shipped
        tyre database (:func:`~tyrebayes.inference.tyre.curve_prior.curve_shape_prior`; 0 to
        0.80 among them, mean 0.263, sd 0.246). Off by default because slip windows are
        traction only, where the load follows the force, so q bends the slip-force relation
        like the curve's shape does and a drive hardly tells them apart: its prior mean then
        moves C_x. On the package's simulator, whose tyres have the database's load
        dependences, it helps; on the independent generator's drives, whose tyres have none, it
        costs (module docstring).
    slip_offset_sd : float
        Per-drive slip at zero force [-]: rolling radii differ by fractions of a percent
        (DESIGN.md physics notes), the driven-minus-reference difference has sd ~0.004.
    force_gain_log_sd : float
        Log-scale sd of the per-drive force gain g_d, the measured over the true ρ_x. The mass
        cancels from F_x/F_z; what does not is where it sits and how the IMU reads a_x: the static
        load share of the driven axle ±2 % (passengers, luggage), the IMU scale factor ±1 %, the
        pitch gradient's over-read of a_x ±0.5 %.
        :class:`~tyrebayes.simulate.vehicle_truth.VehicleSpread` draws cars with these errors;
        their gains have a log-sd of 0.023, rounded up to 0.025 for the CoG height's
        load-transfer error. (It was 0.04 with the mass counted, which does
        not enter ρ_x, and C_x's intervals were wider than its errors: 90 % coverage 1.00.)
    force_spread_scale : float
        Half-normal scale of the spread τ_d of the true force within a drive [-].
    abs_force_ratio, abs_force_ratio_sd : float
        Window-mean |ρ_x| of an ABS window as a fraction of μ_max, and its spread: ABS cycles
        the slip around the peak (about 0.5–1.5 peak slip), where the brush curve delivers
        0.9–1.0 μ and measured Magic Formula curves 0.9–1.0 μ (they fall slowly after the peak);
        0.97 ± 0.04, so 1.05 is two sds out.
    curve_shape_min, curve_bend_median, curve_bend_log_sd : float
        The shape exponent p of the ``"shaped"`` model is p_min + b with b log-normal (median,
        log-sd). p = 1 is the brush model; a measured Magic Formula curve (Pacejka 2006,
        205/60R15) is matched by p = 2.04 to 0.07 % of its slip below 70 % of the peak. p_min 0.5,
        median 1.2, log-sd 0.4: p between 1.1 and 2.8 with 90 %, median 1.7 — tyres are mostly
        Magic-Formula-like, and a brush-like curve lies in the prior's tail, not at a bound. C_x
        moves with p (a straighter start fits the same bending data with a lower C_x), so the
        prior's pull on p is a pull on C_x. On 30 + 30 one-hour drives
        (``benchmarks/results/shape_prior.json``) brush truth gave C_x −0.6 % (fitted p 1.06)
        and Magic Formula truth +1.2 % with this prior, −1.6 % (p 1.16) and +1.4 % with a prior
        bounded at p ≥ 1 (p − 1 log-normal, median 0.5, log-sd 1). p < 1 (bending before the
        brush) reads force noise as early bending without the deconvolved force density; with it
        it does not (skewed-force test windows, seeds 3-5: C_x −1.9 to −4.7 % with this prior,
        −1.1 to −4.2 % with p ≥ 1). Log-normal rather than half-normal: the sampler sees log b,
        whose prior tail is then Gaussian (with a half-normal NUTS did not converge on a
        one-hour drive: R-hat 1.021, a divergence).
    curve_shape_excess_log_mean, curve_shape_excess_log_sd : float
        Normal prior of log(C − 1), C the Magic Formula shape factor of the default ``"magic"``
        curve; and ``curve_curvature_log_mean``, ``curve_curvature_log_sd`` that of log(1 − E),
        E its curvature factor. The spread of the 9 distinct car/SUV sets of the shipped tyre
        database (:func:`~tyrebayes.inference.tyre.curve_prior.curve_shape_prior`, sds widened by
        √(1 + 1/9)): C 1.32-1.84 and E −4.1-0.63 among them, 90 % prior intervals C 1.33-1.87
        and E −2.3-0.72. At 30 % of the peak these tyres' secant slope is 0.97-1.02 of the slope
        at zero (the brush's 0.89), so a drive that stays there carries that range into C_x.
    force_noise_log_sd, slip_noise_log_sd : float
        Log-scale sds of λ_ρ and λ_σ, the scales on the stated force and slip noise (median 1:
        the stream states the noise it measured).
    slip_drift_median, slip_drift_log_sd : float
        Log-normal prior of τ, the sd of the slip offset each block of
        :data:`~tyrebayes.inference.tyre.data.BLOCK_S` seconds adds to its drive's offset [-].
        Slow slip errors come from rolling radii that drift with tyre temperature and pressure
        (0.05-0.1 % of radius over minutes: 5e-4-1e-3 of slip) and from slow force errors that
        the slip regression reads as slip (an IMU bias wandering by 0.1-0.2 m/s², road grade
        the features did not remove: 0.01-0.03 of ρ_x, 2e-4-6e-4 of slip at C_x = 50); a median
        of 3e-4 puts 90 % between 6e-5 and 1.6e-3; 0 leaves the blocks out. On the 16 external
        drives the blocks took C_x from +2.4 % (90 % coverage 14 of 16, 10 drives flagged for
        correlated slip errors) to +1.4 % (15 of 16, 2 flagged); on the
        package's own simulator they did not help (``benchmarks/results/block_offsets.json``,
        6 twenty-minute drives with ABS: C_x RMSE 6.1 % with them, 3.8 % without; one drive
        whose slip errors drift, variance inflation 6.9, +12.7 % against +3.0 %): within 5 s
        that drive's slip and force do not follow the curve, and why has not been found.

    Examples
    --------
    >>> priors = TyrePriors()
    >>> TyrePriors(c_xr_median=2 * priors.c_xr_median).c_xr_median > priors.c_xr_median
    True
    """

    c_xr_median: float = 35.0
    c_xr_log_sd: float = 0.45
    temp_sensitivity_mean: float = 0.008
    temp_sensitivity_sd: float = 0.006
    load_sensitivity_mean: float = 0.263
    load_sensitivity_sd: float = 0.0
    slip_offset_sd: float = 0.004
    force_gain_log_sd: float = 0.025
    force_spread_scale: float = 0.3
    abs_force_ratio: float = 0.97
    abs_force_ratio_sd: float = 0.04
    curve_shape_min: float = 0.5
    curve_bend_median: float = 1.2
    curve_bend_log_sd: float = 0.4
    curve_shape_excess_log_mean: float = -0.625
    curve_shape_excess_log_sd: float = 0.292
    curve_curvature_log_mean: float = -0.006
    curve_curvature_log_sd: float = 0.768
    force_noise_log_sd: float = 0.5
    slip_noise_log_sd: float = 0.3
    slip_drift_median: float = 3e-4
    slip_drift_log_sd: float = 1.0

    @property
    def load_sensitive(self) -> bool:
        """Whether the model has a load sensitivity q (``load_sensitivity_sd > 0``)."""
        return self.load_sensitivity_sd > 0

    def with_load_sensitivity(self) -> TyrePriors:
        """These priors with q's prior the measured tyres' spread, Normal(0.263, 0.246)."""
        return eqx.tree_at(
            lambda p: (p.load_sensitivity_mean, p.load_sensitivity_sd),
            self,
            MEASURED_LOAD_SENSITIVITY,
        )

    def mu_median(self, surfaces: tuple[str, ...]) -> jax.Array:
        return jnp.array([MU_MEDIAN[s] for s in surfaces])

    def mu_log_sd(self, surfaces: tuple[str, ...]) -> jax.Array:
        """Log-scale prior sd of μ_max on each surface (``surface_friction.MU_LOG_SD``)."""
        return jnp.array([MU_LOG_SD[s] for s in surfaces])
