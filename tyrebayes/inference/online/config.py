"""Settings of the online estimator: process noise, Newton steps, change detection, readiness.

Every number says where it comes from. None was fitted to the external drives.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from ...internal.renamed import renamed_keyword
from ...internal.validation import check_nonnegative, check_positive_or_inf
from ..tyre.adequacy import EXCITATION_FORCE, MAX_C_XR_PRIOR_SDS
from .parameters import parameter_names
from .windows import STEP_S

# Random-walk sd of each coordinate of θ per √second. Slow change only: abrupt change is the
# change detector's. C_xr and μ_max: tread wear, inflation pressure and a road surface that
# changes gradually move them by ~2 % over an hour of driving (temperature is the κ term's, not
# drift); 0.02 per √hour = 3.3e-4 per √s. The drive's slip offset: rolling radii drift with tyre
# temperature and pressure by 0.05-0.1 % of radius over tens of minutes (TyrePriors'
# slip_drift_median), faster drifts are the 5 s blocks' own offsets: 1e-3 per √hour. The force
# gain: the load share changes with fuel and passengers (stops), 1 % per √hour. The shape, κ and
# the ABS force ratio are properties of the tyre: no drift. The noise scales revert instead
# (REVERSION_S).
_PER_SQRT_HOUR = 1.0 / 60.0
DRIFT_PER_SQRT_S = {
    "log_c_xr": 0.02 * _PER_SQRT_HOUR,
    "log_mu_max": 0.02 * _PER_SQRT_HOUR,
    "slip_offset": 1e-3 * _PER_SQRT_HOUR,
    "log_force_gain": 0.01 * _PER_SQRT_HOUR,
}

# Correlation time [s] of the coordinates that revert to their prior (:mod:`.process`). The noise
# scales λ_ρ and λ_σ correct the noise the stream measured locally; how far that measure is off
# depends on the road's surface and the speed regime (town, arterial, motorway), which change
# within a drive over a quarter of an hour: 15 minutes. With constant factors one burst of 20 σ
# slips held them tens of sds out for the rest of the drive and sent the CUSUM to false alarms
# that restarted C_x far from its value (benchmarks/results/online_outliers.json). Set on
# the package's own cases, not the external drives: at 10 minutes the scales absorbed part of a
# swap's misfit (pair 26 of benchmarks/online_change.py went unfound), at 30 a burst of outliers
# still raised false alarms on most seeds of that test (README, "One burst of outliers").
REVERSION_S = {
    "log_rho_noise_scale": 900.0,
    "log_slip_noise_scale": 900.0,
}

# The C_xr step the change detector is designed for: a tyre swap or a pressure loss moves C_xr by
# 20 % or more (the test case; winter against summer tyres differ by more).
CHANGE_LOG_SHIFT = math.log(1.2)
# At most one false alarm per 100 hours, half of it for each detector. The mid-drive CUSUM:
# steps start at least STEP_S (30 s) apart (:mod:`.windows`), so at most 120 an hour; a
# one-sided CUSUM of exact log-likelihood ratios has an average run length to false alarm of at
# least e^h steps (Wald's inequality; Siegmund 1985, ch. II.6), two sides at least e^h/2, so
# h = log(2 · 120 / 0.005) = 10.8. The drive-start swap test: at most e^-h per drive start
# (Ville's inequality, :mod:`.swap`); drives of 15 minutes or longer start at most 4 times an
# hour, so h = log(4 / 0.005) = 6.7. Both hold when the likelihood is right
# (benchmarks/online_change.py counts the alarms on windows drawn from it and on simulated
# drives).
FALSE_ALARMS_PER_HOUR = 0.01
MAX_STEPS_PER_HOUR = 3600.0 / STEP_S
MAX_DRIVE_STARTS_PER_HOUR = 4.0
CHANGE_THRESHOLD = math.log(2.0 * MAX_STEPS_PER_HOUR / (FALSE_ALARMS_PER_HOUR / 2.0))
SWAP_THRESHOLD = math.log(MAX_DRIVE_STARTS_PER_HOUR / (FALSE_ALARMS_PER_HOUR / 2.0))


def _float(value) -> Float[Array, ""]:
    return jnp.asarray(value, dtype=float)


def _int(value) -> Int[Array, ""]:
    return jnp.asarray(value, dtype=jnp.int32)  # as the filter state's counters


class OnlineConfig(eqx.Module):
    """How the online estimator filters, detects change and judges readiness.

    Attributes
    ----------
    drift_sd_per_sqrt_s : Float[Array, "p"]
        Random-walk sd of each θ coordinate per √s (:data:`DRIFT_PER_SQRT_S`, 0 elsewhere).
    reversion_s : Float[Array, "p"]
        Correlation time of each θ coordinate that reverts to its prior [s]
        (:data:`REVERSION_S`, ``inf`` elsewhere; :mod:`.process`).
    newton_steps : int
        Most Newton iterations of each Laplace update (static): the first blocks from a wide
        prior (the start, a restart, the swap test's challenger) can need many. Stopping such
        a block short of its mode takes its information at the wrong point, and the too-small
        covariance then holds the estimate there (a challenger adopted after a swap stayed
        short of the new tyre's C_x with 3 iterations).
    gauss_newton : bool
        Take each update's curvature as the block's Gauss-Newton information
        (:func:`~.block_likelihood.block_curvature`: the windows' quantities differentiated
        once) instead of its exact Hessian (static; True: about half the cost of an exact
        Hessian of the Magic Formula's block, ``benchmarks/online_speed.py``).
    newton_tolerance : float
        ... and no more once a step is shorter than this many posterior sds: a settled
        posterior takes two, the second confirming the first. It also sets how exactly the
        blocks' Laplace evidences, which the swap test compares, are taken.
    change_log_shift : float
        The C_xr step (log) the CUSUM tests for, in both directions.
    change_threshold : float
        CUSUM alarm level [nats] (:data:`CHANGE_THRESHOLD`: ≤ 0.5 false alarms per 100 h).
    change_min_steps : int
        A step adds at most ``change_threshold / (change_min_steps − ½)`` to the CUSUM per
        STEP_S it spans (at least one), so an alarm needs this many STEP_S of driving (3:
        90 s) and, with steps of at most PACKED_STEP_S = 60 s, two steps at least
        (:mod:`.change`).
    swap_threshold : float
        Log Bayes factor of a swap at the drive start that raises an alarm [nats]
        (:data:`SWAP_THRESHOLD`: ≤ 0.5 false alarms per 100 h).
    swap_window_steps : int
        Steps after a drive start that the swap test runs (20: ten minutes of steps that start
        30 s apart, more where steps pack sparse driving, :mod:`.windows`; the challenger
        filter costs a second update per step while it runs).
    change_gate_log_sd : float
        The CUSUM accumulates only while the posterior sd of log C_xr is below this: before
        that, the estimate's own movement is not a change (and its Gaussian is the crudest).
        0.06 is the readiness width (90 % interval ±10 %).
    ready_half_width : float
        "Enough evidence" needs the 90 % interval of C_x within ± this fraction of its mean.
    min_slip_windows : int
        ... and this many slip windows since the (re)start (240: one minute of pushing windows).
    min_excited_windows : int
        ... and this many windows with |ρ_x| ≥ ``excitation_force`` (a slope needs forces
        away from zero: 120 windows, 30 s).
    excitation_force : float
        Force of an exciting window [-]: 0.05, beyond the force noise (±0.01, PUSHING_MARGIN);
        the batch fit's excitation check counts the same windows
        (:data:`~tyrebayes.inference.tyre.adequacy.EXCITATION_FORCE`).
    max_prior_z : float
        C_x is withheld while the mean of log C_xr lies more than this many type-prior sds
        from the type's median (4: with the prior's log-sd 0.45 a factor of 6 either way, far
        beyond any tyre of the type; such a value comes from a model that does not fit). The
        batch fit flags a C_xr at the same distance
        (:data:`~tyrebayes.inference.tyre.adequacy.MAX_C_XR_PRIOR_SDS`).
    initial_inflation : float
        Slip-error variance inflation assumed until :data:`~..window_correlation.MIN_BLOCKS`
        batch-means blocks have estimated it (2.0: the package's own simulated drive gave
        2.2-2.4, :mod:`~tyrebayes.inference.tyre.window_correlation`); the estimate then takes over
        as blocks accrue (it weighs as ``inflation_prior_blocks`` blocks).
    inflation_prior_blocks : float
        Weight of ``initial_inflation`` in batch-means blocks.
    mu_observed_contraction : float
        μ_max is reported only after an ABS window and once its log-sd has shrunk by this
        fraction of the prior's (the batch fit's rule, ``MU_OBSERVED_CONTRACTION``).

    Examples
    --------
    :func:`default_config` fills the per-coordinate drifts and reversions for a model's θ:

    >>> config = default_config("magic")
    >>> config.drift_sd_per_sqrt_s.shape, int(config.min_slip_windows)
    ((11,), 240)
    >>> float(config.change_threshold) == CHANGE_THRESHOLD
    True
    >>> default_config(min_slip_windows=100).min_slip_windows.item()
    100
    """

    drift_sd_per_sqrt_s: Float[Array, "p"]
    reversion_s: Float[Array, "p"]
    newton_steps: int = eqx.field(static=True, default=10)
    gauss_newton: bool = eqx.field(static=True, default=True)
    # The settings below are values the compiled filter takes, not constants in it: another
    # threshold or window count reuses the program compiled for the defaults.
    newton_tolerance: Float[Array, ""] = eqx.field(converter=_float, default=0.05)
    change_log_shift: Float[Array, ""] = eqx.field(converter=_float, default=CHANGE_LOG_SHIFT)
    change_threshold: Float[Array, ""] = eqx.field(converter=_float, default=CHANGE_THRESHOLD)
    change_min_steps: Int[Array, ""] = eqx.field(converter=_int, default=3)
    swap_threshold: Float[Array, ""] = eqx.field(converter=_float, default=SWAP_THRESHOLD)
    swap_window_steps: Int[Array, ""] = eqx.field(converter=_int, default=20)
    change_gate_log_sd: Float[Array, ""] = eqx.field(converter=_float, default=0.06)
    ready_half_width: Float[Array, ""] = eqx.field(converter=_float, default=0.10)
    min_slip_windows: Int[Array, ""] = eqx.field(converter=_int, default=240)
    min_excited_windows: Int[Array, ""] = eqx.field(converter=_int, default=120)
    excitation_force: Float[Array, ""] = eqx.field(converter=_float, default=EXCITATION_FORCE)
    max_prior_z: Float[Array, ""] = eqx.field(converter=_float, default=MAX_C_XR_PRIOR_SDS)
    initial_inflation: Float[Array, ""] = eqx.field(converter=_float, default=2.0)
    inflation_prior_blocks: Float[Array, ""] = eqx.field(converter=_float, default=10.0)
    mu_observed_contraction: Float[Array, ""] = eqx.field(converter=_float, default=0.5)

    def __check_init__(self):
        if self.newton_steps < 1:
            raise ValueError(f"newton_steps: expected ≥ 1, got {self.newton_steps}")
        if self.change_min_steps < 1:
            raise ValueError(f"change_min_steps: expected ≥ 1, got {self.change_min_steps}")
        check_nonnegative("OnlineConfig", "drift_sd_per_sqrt_s", self.drift_sd_per_sqrt_s)
        check_positive_or_inf("OnlineConfig", "reversion_s", self.reversion_s)
        if self.reversion_s.shape != self.drift_sd_per_sqrt_s.shape:
            raise ValueError(
                f"OnlineConfig: expected reversion_s shaped as drift_sd_per_sqrt_s "
                f"{self.drift_sd_per_sqrt_s.shape}, got {self.reversion_s.shape}"
            )


@renamed_keyword("kind", "model", what="the tyre-curve model")
def default_config(model: str = "magic", load_sensitive: bool = False, **changes) -> OnlineConfig:
    """:class:`OnlineConfig` with the stated drifts and reversions for ``model``'s θ (and any
    field changed)."""
    names = parameter_names(model, load_sensitive)
    drift = jnp.asarray([DRIFT_PER_SQRT_S.get(n, 0.0) for n in names], dtype=float)
    reversion = jnp.asarray([REVERSION_S.get(n, jnp.inf) for n in names], dtype=float)
    return OnlineConfig(
        drift_sd_per_sqrt_s=changes.pop("drift_sd_per_sqrt_s", drift),
        reversion_s=changes.pop("reversion_s", reversion),
        **changes,
    )


__all__ = [
    "CHANGE_THRESHOLD",
    "SWAP_THRESHOLD",
    "DRIFT_PER_SQRT_S",
    "REVERSION_S",
    "OnlineConfig",
    "default_config",
]
