"""What the online estimator reports at a step, and whether it has the evidence to report it.

C_x is reported at the mean tyre temperature of the windows since the (re)start, as the batch
fit does (``c_x`` of :func:`~tyrebayes.inference.tyre.model.tyre_model`): log C_x = log C_xr −
κ(T̄ − 20 °C) is linear in θ, so it is Gaussian under the filter and C_x log-normal. Intervals are
the log-normal's central 90 % intervals (for the sds a step carries, a fraction of a percent
from its 90 % HDI), keyed ``hdi_90`` as every summary of the package.

"Enough evidence" (``ready``) for C_x and C_xr: their 90 % interval lies within
±``ready_half_width`` of the mean AND the windows since the (re)start excite the tyre (enough
slip windows, enough of them at a force away from zero) AND its C_xr lies within
``max_prior_z`` type-prior sds of the type's median: a value beyond that says the model does not
fit the windows, not what the tyre is. μ_max has its own rule: an ABS window
was seen and the posterior sd of log μ_max has shrunk by half from the prior's; an observed
μ_max that puts the drive's surface label in doubt, as in the batch fit's adequacy
(:func:`~tyrebayes.inference.tyre.adequacy.label_in_doubt`: beyond 4 prior sds of the label's
median, or 20 times likelier under a grippier surface's prior), is reported with a note. A value
that is not ready is reported as missing, with the reason (:meth:`OnlineSummary.to_dict`).

Neither is reported while the tyre's other coordinates
(:data:`~tyrebayes.inference.online.parameters.PRIOR_CHECKED`: the curve's shape, the ABS force
ratio, the temperature and load sensitivities) are in conflict with the type prior: one of them
beyond ``max_prior_z`` prior sds from its prior mean, or all of them together as far out, by
their Mahalanobis distance under the prior (:func:`joint_prior_sds`: the χ² tail probability of
that distance, read as the distance of one coordinate with the same two-sided tail). The filter
is then explaining the windows with a tyre no prior allows, and its C_x and μ_max come from that
misfit. A dry drive labelled ice is the case in point: its ABS forces, three times the ice
prior's μ_max, went into the ABS force ratio and the curve's shape; with the exact Hessian as
the filter's curvature one of them ended beyond 5 prior sds, with the Gauss-Newton curvature
the misfit spread over four of them, none past 4 sds alone, and only their joint distance
shows it (``benchmarks/results/identification.json``). The sensors' noise scales and the
per-drive coordinates are not checked: they are the sensors' and the drive's, not the tyre's.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ..._domain import SURFACES
from ...physics.thermal import REFERENCE_TEMPERATURE_C
from ..tyre.adequacy import MAX_LABEL_LOG_BAYES_FACTOR, MAX_MU_PRIOR_SDS, label_in_doubt

_Z90 = 1.6448536269514722

# Reasons a C_x value is withheld (codes in OnlineSummary.reason, texts in OnlineSummary.to_dict).
READY, TOO_LITTLE_EXCITATION, INTERVAL_TOO_WIDE, OUTSIDE_TYPE, PRIOR_CONFLICT = 0, 1, 2, 3, 4
REASONS = {
    READY: "",
    TOO_LITTLE_EXCITATION: "too little excitation: too few windows pushing the tyre",
    INTERVAL_TOO_WIDE: "90 % interval of C_x wider than the readiness width",
    OUTSIDE_TYPE: "C_xr far outside its tyre type's range: the model does not fit these windows",
    PRIOR_CONFLICT: (
        "a tyre parameter far outside its prior (prior_conflict): the model does not fit these "
        "windows; check the surface label and the vehicle file"
    ),
}


class LogNormalSummary(eqx.Module):
    """A log-normal posterior summary (all fields with the caller's leading axes).

    Attributes
    ----------
    mean, sd : Float[Array, "*t"]
        Mean and sd of the value.
    low, high : Float[Array, "*t"]
        Its central 90 % interval.
    """

    mean: Float[Array, "*t"]
    sd: Float[Array, "*t"]
    low: Float[Array, "*t"]
    high: Float[Array, "*t"]


def log_normal_summary(log_mean, log_sd) -> LogNormalSummary:
    """Summary of exp(X), X ~ Normal(log_mean, log_sd²)."""
    mean = jnp.exp(log_mean + 0.5 * log_sd**2)
    sd = mean * jnp.sqrt(jnp.expm1(log_sd**2))
    return LogNormalSummary(
        mean=mean,
        sd=sd,
        low=jnp.exp(log_mean - _Z90 * log_sd),
        high=jnp.exp(log_mean + _Z90 * log_sd),
    )


class OnlineSummary(eqx.Module):
    """The estimate at one step (or a trajectory: every field gains a leading time axis).

    Attributes
    ----------
    time_s : Float[Array, "*t"]
        Drive time [s].
    c_x, c_xr, mu_max, force_gain : LogNormalSummary
        C_x at the mean tyre temperature since the (re)start, C_xr at 20 °C, μ_max and the
        force gain g [-].
    slip_offset_mean, slip_offset_sd : Float[Array, "*t"]
        The drive's slip at zero force [-].
    ready : Bool[Array, "*t"]
        Enough evidence for C_x and C_xr (module docstring).
    reason : Int[Array, "*t"]
        Why not (:data:`REASONS`), 0 when ready.
    mu_observed : Bool[Array, "*t"]
        μ_max observed (module docstring).
    mu_prior_z : Float[Array, "*t"]
        Mean of log μ_max in prior sds from the surface prior's median: an observed μ_max
        beyond :data:`~tyrebayes.inference.tyre.adequacy.MAX_MU_PRIOR_SDS` puts the drive's
        surface label in doubt, as in the batch fit's adequacy.
    mu_likelier_surface : Int[Array, "*t"]
        The grippier surface (index in :data:`~tyrebayes._domain.SURFACES`) whose μ_max prior
        predicts the estimate best (the label's own on the grippiest surface), and
    mu_label_log_bf : Float[Array, "*t"]
        its log Bayes factor over the label [nats]
        (:func:`~tyrebayes.inference.tyre.adequacy.likelier_surface`): an observed μ_max past
        :data:`~tyrebayes.inference.tyre.adequacy.MAX_LABEL_LOG_BAYES_FACTOR` also puts the label
        in doubt.
    alarm : Bool[Array, "*t"]
        An alarm at this step: the tyre's coordinates restarted from the type prior (a
        mid-drive change), or the challenger's taken over (a swap).
    swap_alarm : Bool[Array, "*t"]
        ... raised by the drive-start swap test (:mod:`.swap`), not by the mid-drive change
        detector (:mod:`.change`).
    n_alarms : Int[Array, "*t"]
        Alarms so far.
    swap_log_bayes_factor : Float[Array, "*t"]
        Log Bayes factor of a tyre swap at the last drive start [nats] (:mod:`.swap`; an alarm
        at its threshold).
    n_slip_windows, n_excited_windows, n_limit_windows : Float[Array, "*t"]
        Windows since the (re)start.
    slip_inflation : Float[Array, "*t"]
        Variance inflation of the slip errors the next step uses.
    prior_conflict : Bool[Array, "*t"]
        One of the tyre's checked coordinates, or all of them jointly, lies beyond
        ``max_prior_z`` prior sds from the prior mean (module docstring): C_x and μ_max are
        withheld.
    conflict_prior_sds : Float[Array, "*t"]
        The checked coordinate farthest from its prior mean: its distance in prior sds, signed.
    conflict_joint_prior_sds : Float[Array, "*t"]
        The checked coordinates' joint distance from the prior mean as one coordinate's
        (:func:`joint_prior_sds`).
    conflict_coordinate : Int[Array, "*t"]
        Its index in θ (``coordinate_names``).
    coordinate_names : tuple of str
        θ's coordinates (static).

    Examples
    --------
    The summary of an estimator that has seen no window yet: C_x is withheld, with the reason
    (:meth:`to_dict`, a step as plain data).

    >>> import equinox as eqx
    >>> from tyrebayes import OnlineEstimator
    >>> estimator = OnlineEstimator.create(model="magic")
    >>> summary = eqx.filter_jit(estimator.summary)(estimator.init())
    >>> record = summary.to_dict()
    >>> record["enough_evidence"], record["c_x"], record["n_slip_windows"]
    (False, None, 0)
    >>> record["reason"]
    'too little excitation: too few windows pushing the tyre'
    """

    time_s: Float[Array, "*t"]
    c_x: LogNormalSummary
    c_xr: LogNormalSummary
    mu_max: LogNormalSummary
    force_gain: LogNormalSummary
    slip_offset_mean: Float[Array, "*t"]
    slip_offset_sd: Float[Array, "*t"]
    ready: Bool[Array, "*t"]
    reason: Int[Array, "*t"]
    mu_observed: Bool[Array, "*t"]
    mu_prior_z: Float[Array, "*t"]
    mu_likelier_surface: Int[Array, "*t"]
    mu_label_log_bf: Float[Array, "*t"]
    alarm: Bool[Array, "*t"]
    swap_alarm: Bool[Array, "*t"]
    n_alarms: Int[Array, "*t"]
    swap_log_bayes_factor: Float[Array, "*t"]
    n_slip_windows: Float[Array, "*t"]
    n_excited_windows: Float[Array, "*t"]
    n_limit_windows: Float[Array, "*t"]
    slip_inflation: Float[Array, "*t"]
    prior_conflict: Bool[Array, "*t"]
    conflict_prior_sds: Float[Array, "*t"]
    conflict_joint_prior_sds: Float[Array, "*t"]
    conflict_coordinate: Int[Array, "*t"]
    coordinate_names: tuple[str, ...] = eqx.field(static=True, default=())

    def to_dict(self, step=()) -> dict:
        """One step as plain data: the entry of ``"trajectory"`` in ``tyrebayes online --json``;
        withheld values are ``None`` with a reason.

        ``step`` indexes the step of a trajectory (default: an unbatched summary).
        """
        ready = bool(np.asarray(self.ready)[step])
        reason = REASONS[int(np.asarray(self.reason)[step])]
        observed = bool(np.asarray(self.mu_observed)[step])
        conflict = bool(np.asarray(self.prior_conflict)[step])
        mu_ok = observed and not conflict
        mu_z = float(np.asarray(self.mu_prior_z)[step])
        label_log_bf = float(np.asarray(self.mu_label_log_bf)[step])
        # None on the grippiest surface's label, where no surface is weighed against it.
        likelier = SURFACES[int(np.asarray(self.mu_likelier_surface)[step])]
        if not np.isfinite(label_log_bf):
            label_log_bf, likelier = None, None
        label_note = _label_note(mu_z, label_log_bf, likelier) if observed else None
        coordinate = int(np.asarray(self.conflict_coordinate)[step])
        conflict_record = {
            "coordinate": (
                self.coordinate_names[coordinate]
                if coordinate < len(self.coordinate_names)
                else str(coordinate)
            ),
            "prior_sds": float(np.asarray(self.conflict_prior_sds)[step]),
            "joint_prior_sds": float(np.asarray(self.conflict_joint_prior_sds)[step]),
        }
        if not observed:
            mu_reason = "not observed: no ABS stop, or too little contraction"
        elif conflict:
            mu_reason = f"withheld: {REASONS[PRIOR_CONFLICT]}"
        else:
            mu_reason = None
        record = {
            "time_s": float(np.asarray(self.time_s)[step]),
            "enough_evidence": ready,
            "reason": None if ready else reason,
            "c_x": _value(self.c_x, step) if ready else None,
            "c_xr": _value(self.c_xr, step) if ready else None,
            "mu_max": _value(self.mu_max, step) if mu_ok else None,
            "mu_max_reason": mu_reason,
            "mu_max_prior_sds": mu_z,
            "mu_max_label_log_bayes_factor": label_log_bf,
            "mu_max_likelier_surface": likelier,
            "mu_max_note": label_note,
            "slip_offset": {
                "mean": float(np.asarray(self.slip_offset_mean)[step]),
                "sd": float(np.asarray(self.slip_offset_sd)[step]),
                "hdi_90": [
                    float(np.asarray(self.slip_offset_mean - _Z90 * self.slip_offset_sd)[step]),
                    float(np.asarray(self.slip_offset_mean + _Z90 * self.slip_offset_sd)[step]),
                ],
            },
            "force_gain": _value(self.force_gain, step),
            "alarm": bool(np.asarray(self.alarm)[step]),
            "alarm_kind": _alarm_kind(self, step),
            "n_alarms": int(np.asarray(self.n_alarms)[step]),
            "swap_log_bayes_factor": float(np.asarray(self.swap_log_bayes_factor)[step]),
            "n_slip_windows": int(np.asarray(self.n_slip_windows)[step]),
            "n_excited_windows": int(np.asarray(self.n_excited_windows)[step]),
            "n_abs_windows": int(np.asarray(self.n_limit_windows)[step]),
            "slip_inflation": float(np.asarray(self.slip_inflation)[step]),
            "prior_conflict": conflict_record if conflict else None,
        }
        return record


class StateMoments(eqx.Module):
    """What a step's summary reads of the filter state: θ's mean and sds, the mean and sd of
    log C_x at the mean tyre temperature since the (re)start, and the counters and flags
    (every field with the caller's leading axes).

    The covariance enters a summary only through these, so a trajectory keeps them per step
    and summarises every step at once after the scan (:meth:`~.estimator.OnlineEstimator.run`).
    """

    time_s: Float[Array, "*t"]
    mean: Float[Array, "*t p"]
    sd: Float[Array, "*t p"]
    log_c_x_mean: Float[Array, "*t"]
    log_c_x_sd: Float[Array, "*t"]
    n_slip_windows: Float[Array, "*t"]
    n_excited_windows: Float[Array, "*t"]
    n_limit_windows: Float[Array, "*t"]
    alarm: Bool[Array, "*t"]
    swap_alarm: Bool[Array, "*t"]
    n_alarms: Int[Array, "*t"]
    log_bayes_factor: Float[Array, "*t"]
    slip_inflation: Float[Array, "*t"]


def joint_prior_sds(offset: Float[Array, "k"], prior_cov: Float[Array, "k k"]) -> Float[Array, ""]:
    """How far k coordinates lie from their prior mean together, in one coordinate's sds.

    The squared Mahalanobis distance d²  = offsetᵀ prior_cov⁻¹ offset has a χ²_k tail probability
    p = Q(k/2, d²/2) when the coordinates are drawn from the prior; the result is the z with
    the same two-sided Normal tail, P(|Z| > z) = p, so one threshold in sds serves a single
    coordinate and the k together (z = |offset|/sd for k = 1). A posterior mean lies nearer the
    prior's than a draw from it, so the tail is conservative for it.
    """
    k = offset.shape[0]
    d2 = offset @ jnp.linalg.solve(prior_cov, offset)
    tail = jax.scipy.special.gammaincc(k / 2.0, d2 / 2.0)
    return -jax.scipy.special.ndtri(0.5 * tail)


def c_x_direction(n_params: int, mean_temperature_c, index: dict, dtype=float):
    """Coefficients a with log C_x = aᵀθ at the given mean tyre temperature."""
    a = jnp.zeros(n_params, dtype=dtype).at[index["log_c_xr"]].set(1.0)
    return a.at[index["temp_sensitivity"]].set(-(mean_temperature_c - REFERENCE_TEMPERATURE_C))


def readiness(c_x: LogNormalSummary, n_slip, n_excited, prior_z, config, conflict=False) -> tuple:
    """(ready, reason) for C_x (module docstring); ``prior_z`` is the distance of log C_xr's
    mean from the type prior's in prior sds, ``conflict`` whether another of the tyre's
    coordinates is in conflict with its prior."""
    narrow = (c_x.high <= (1.0 + config.ready_half_width) * c_x.mean) & (
        c_x.low >= (1.0 - config.ready_half_width) * c_x.mean
    )
    excited = (jnp.asarray(n_slip) >= config.min_slip_windows) & (
        jnp.asarray(n_excited) >= config.min_excited_windows
    )
    typical = jnp.abs(prior_z) <= config.max_prior_z
    reason = jnp.where(
        ~excited,
        TOO_LITTLE_EXCITATION,
        jnp.where(
            ~typical,
            OUTSIDE_TYPE,
            jnp.where(conflict, PRIOR_CONFLICT, jnp.where(narrow, READY, INTERVAL_TOO_WIDE)),
        ),
    )
    return excited & typical & ~jnp.asarray(conflict) & narrow, reason


def _value(s: LogNormalSummary, i) -> dict:
    lo, hi = float(np.asarray(s.low)[i]), float(np.asarray(s.high)[i])
    return {
        "mean": float(np.asarray(s.mean)[i]),
        "sd": float(np.asarray(s.sd)[i]),
        "hdi_90": [lo, hi],
    }


def _label_note(prior_sds: float, label_log_bf: float | None, likelier: str | None) -> str | None:
    """The note on an observed μ_max that puts its surface label in doubt (None if it does not)."""
    if not label_in_doubt(prior_sds, -np.inf if label_log_bf is None else label_log_bf):
        return None
    if abs(prior_sds) > MAX_MU_PRIOR_SDS:
        return (
            f"{prior_sds:+.1f} prior sds from the surface's median (beyond {MAX_MU_PRIOR_SDS:g}): "
            "check the drive's surface label"
        )
    return (
        f"{np.exp(label_log_bf):.0f} times likelier under the {likelier} prior (Bayes factor "
        f"beyond {np.exp(MAX_LABEL_LOG_BAYES_FACTOR):.0f}): check the drive's surface label"
    )


def _alarm_kind(summary: OnlineSummary, i) -> str:
    """The detector of the alarm at step ``i``: "swap" (the drive-start swap test), "change"
    (the mid-drive detector) or "" (no alarm)."""
    if not bool(np.asarray(summary.alarm)[i]):
        return ""
    return "swap" if bool(np.asarray(summary.swap_alarm)[i]) else "change"


__all__ = [
    "PRIOR_CONFLICT",
    "REASONS",
    "LogNormalSummary",
    "OnlineSummary",
    "StateMoments",
    "log_normal_summary",
    "joint_prior_sds",
    "readiness",
]
