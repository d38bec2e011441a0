"""The online estimator's state: a Gaussian over θ and the running sums it is judged by.

Fixed size whatever the driving time: what grows with the data are counts and sums.
"""

from __future__ import annotations

import equinox as eqx
from jaxtyping import Array, Bool, Float, Int


class InflationSums(eqx.Module):
    """Running batch-means sums of the standardised slip residuals (the variance inflation).

    The batch fit weighs each drive's slips by 1/VIF, VIF from batch means over
    ``BLOCK_WINDOWS`` consecutive slip windows of its standardised residuals
    (:func:`~tyrebayes.inference.tyre.window_correlation.variance_inflation`).
    These are that estimate's sums, accrued as residuals arrive (each at the mode of its step).

    Attributes
    ----------
    sum_z, sum_z2 : Float[Array, ""]
        Σz and Σz² over all slip windows so far.
    n_z : Float[Array, ""]
        Their number.
    partial_sum : Float[Array, ""]
        Σz over the batch-means block being filled.
    partial_count : Float[Array, ""]
        Windows in it so far.
    sum_block, sum_block2 : Float[Array, ""]
        Σ and Σ² of the completed blocks' sums.
    n_blocks : Float[Array, ""]
        Completed blocks.
    """

    sum_z: Float[Array, ""]
    sum_z2: Float[Array, ""]
    n_z: Float[Array, ""]
    partial_sum: Float[Array, ""]
    partial_count: Float[Array, ""]
    sum_block: Float[Array, ""]
    sum_block2: Float[Array, ""]
    n_blocks: Float[Array, ""]


class FilterState(eqx.Module):
    """State of the online estimator of one car (leading axes for many cars under vmap).

    Attributes
    ----------
    mean : Float[Array, "p"]
        Posterior mean of θ (:func:`~.parameters.parameter_names`).
    cov : Float[Array, "p p"]
        Posterior covariance of θ.
    time_s : Float[Array, ""]
        Drive time of the last step [s].
    start_s : Float[Array, ""]
        Drive time of the last (re)start from the type prior [s].
    n_slip_windows, n_excited_windows, n_limit_windows : Float[Array, ""]
        Slip windows, slip windows with |ρ_x| ≥ the excitation force, ABS windows since the
        (re)start.
    temperature_sum : Float[Array, ""]
        Σ of the slip windows' tyre temperatures since the (re)start [°C] (C_x is reported at
        their mean, as the batch fit does).
    cusum_up, cusum_down : Float[Array, ""]
        CUSUM statistics of a C_xr step up and down [nats].
    challenger_mean : Float[Array, "p"]
        Mean of the swap test's challenger: θ with the tyre's coordinates started again from
        the prior at the last drive start (:mod:`.swap`).
    challenger_cov : Float[Array, "p p"]
        Its covariance.
    log_bayes_factor : Float[Array, ""]
        Log Bayes factor of a swap at the last drive start [nats].
    drive_steps : Int[Array, ""]
        Steps since the last drive start; the swap test runs while it is below
        ``swap_window_steps``, and a start it does not test is counted from there.
    n_alarms : Int[Array, ""]
        Change alarms so far.
    alarm : Bool[Array, ""]
        The last step raised an alarm (and restarted from the type prior, or took the
        challenger's estimate).
    swap_alarm : Bool[Array, ""]
        ... and it was the drive-start swap test's (the estimate is the challenger's, which
        learned the new tyre since the drive start), not the mid-drive change detector's.
    inflation : InflationSums
        The slip errors' running variance-inflation sums (kept across restarts: a property of
        the sensors, not of the tyre).
    """

    mean: Float[Array, "p"]
    cov: Float[Array, "p p"]
    time_s: Float[Array, ""]
    start_s: Float[Array, ""]
    n_slip_windows: Float[Array, ""]
    n_excited_windows: Float[Array, ""]
    n_limit_windows: Float[Array, ""]
    temperature_sum: Float[Array, ""]
    cusum_up: Float[Array, ""]
    cusum_down: Float[Array, ""]
    challenger_mean: Float[Array, "p"]
    challenger_cov: Float[Array, "p p"]
    log_bayes_factor: Float[Array, ""]
    drive_steps: Int[Array, ""]
    n_alarms: Int[Array, ""]
    alarm: Bool[Array, ""]
    swap_alarm: Bool[Array, ""]
    inflation: InflationSums


__all__ = ["FilterState", "InflationSums"]
