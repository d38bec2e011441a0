"""Uncertainty-aware warnings: is a tyre set unsuitable for winter? Does it wear unexpectedly fast?

:func:`high_wear_warning` warns when the posterior probability that a set's wear rate exceeds a
multiple of a reference rate is high (relative wear draws from :mod:`tyrebayes.inference.wear`).

The winter rule, for predictive draws of the set's snow friction mu_snow (from
:func:`tyrebayes.inference.fleet.predict_friction`):

1. ``p = P(mu_snow < mu_min)``.
2. Bayes decision with costs: warning costs ``cost_false_alarm`` when the set is fine; silence costs
   ``cost_miss`` when it is not. Warning has the lower expected cost when
   ``p > threshold = cost_false_alarm / (cost_false_alarm + cost_miss)``.
3. But a warning (or an all-clear) that rests on a prediction too vague to tell is not given: when
   the central 90 % predictive interval reaches more than ``straddle_tol`` below *and* above
   ``mu_min``, the verdict is ``"insufficient_evidence"``.

Defaults and where they come from
---------------------------------
``mu_min`` (snow) = :data:`DEFAULT_MU_MIN_SNOW` = 0.26, derived by :func:`derive_mu_min_snow` from
the shipped braking data (``tyrebayes/data/braking_by_tyre_type.csv``): winter sets on snow
decelerate at 0.338-0.450 g on average (lower bounds on their mu_max, the lowest is ADAC 2018's
0.338); summer sets need "more than twice" the winter distance (What Car?), i.e. decelerate at
< 0.180 g. The midpoint of that gap, 0.259, rounded to 0.26, passes every measured winter (and
all-season) set with margin and fails summer sets. (The thesis' 0.45 is the edge of its
low-friction road region, not a tyre verdict.)

``cost_miss`` = 9, ``cost_false_alarm`` = 1, so ``threshold`` = 0.1: driving winter roads on an
unsuitable set is judged nine times worse than an unneeded tyre check.

``straddle_tol`` = 0.08: a set whose type and stiffness are well known still has a 90 % predictive
interval of about +-0.05 around its mean on snow (the residual scatter, ~0.03), so 0.08 on both
sides of ``mu_min`` only happens when the stiffness, the type or the fleet fit itself is
uncertain.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from ._domain import MU_RANGE, load_braking_data, mean_deceleration_g
from ._errors import BadInputError
from .inference.summary import summarize

#: Default minimum snow friction potential for a winter-suitable set (see module docstring).
DEFAULT_MU_MIN_SNOW: float = 0.26
#: Default cost of a missed unsuitable set relative to a false alarm.
DEFAULT_COST_MISS: float = 9.0
DEFAULT_COST_FALSE_ALARM: float = 1.0
#: How far the 90 % predictive interval may reach past mu_min on both sides before the verdict
#: becomes "insufficient_evidence".
DEFAULT_STRADDLE_TOL: float = 0.08


@dataclasses.dataclass(frozen=True)
class WinterVerdict:
    """A set's winter-suitability verdict (:func:`winter_verdict`).

    Attributes
    ----------
    verdict : str
        ``"ok"``, ``"warn"`` or ``"insufficient_evidence"``.
    probability : float
        P(mu_snow < mu_min) over the predictive draws.
    threshold : float
        The cost threshold ``c_fa / (c_fa + c_miss)`` the probability is judged against.
    mu_min : float
        Minimum acceptable mu on snow.
    mu : dict
        Summary of the draws (:func:`~tyrebayes.inference.summary.summarize`, as a dict).
    interval_90 : list of float
        Central 90 % interval of the draws.
    costs : dict
        ``false_alarm`` and ``miss``.
    straddle_tol : float
        Reach past ``mu_min`` on both sides that makes the evidence insufficient.
    n_draws : int
        Finite draws used.
    reason : str
        One sentence.

    Examples
    --------
    >>> v = winter_verdict(np.random.default_rng(0).normal(0.18, 0.03, 4000))
    >>> v.verdict, v.to_dict()["verdict"]
    ('warn', 'warn')
    """

    verdict: str
    probability: float
    threshold: float
    mu_min: float
    mu: dict
    interval_90: list[float]
    costs: dict[str, float]
    straddle_tol: float
    n_draws: int
    reason: str

    def to_dict(self) -> dict:
        """The fields as a dict, in order (the ``warn`` command's JSON)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


@dataclasses.dataclass(frozen=True)
class WearWarning:
    """The "unexpectedly high wear" decision (:func:`high_wear_warning`).

    Attributes
    ----------
    warning : bool
        P(wear rate ratio > threshold) reached the decision probability.
    probability : float
        P(ratio > threshold) over the draws.
    threshold : float
        Ratio of the wear rate to its reference that counts as high.
    message : str
        One line.

    Examples
    --------
    >>> high_wear_warning(np.full(100, 1.3)).to_dict()["warning"]
    True
    """

    warning: bool
    probability: float
    threshold: float
    message: str

    def to_dict(self) -> dict:
        """The fields as a dict, in order (``fit-wear``'s ``"high_wear"`` object)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}


def check_mu_min(mu_min: float, name: str = "mu_min") -> float:
    """``mu_min`` as a float, or :class:`BadInputError` when no tyre could have that friction.

    Examples
    --------
    >>> check_mu_min(0.3)
    0.3
    >>> try:
    ...     check_mu_min(30.0, "--mu-min")
    ... except BadInputError as err:
    ...     print(err)
    --mu-min: expected a friction coefficient in (0, 2), got 30 (percent? use 0.3)
    """
    value = float(mu_min)
    lo, hi = MU_RANGE
    if not lo < value < hi:
        hint = f" (percent? use {value / 100:g})" if hi <= value <= 100 * hi else ""
        raise BadInputError(
            f"{name}: expected a friction coefficient in ({lo:g}, {hi:g}), got {value:g}{hint}"
        )
    return value


def stiffness_extrapolation(c_xr: float, fleet_c_xr, what: str = "the fleet") -> dict:
    """Whether a prediction at ``c_xr`` leaves the stiffness range the fleet fit saw.

    The fleet model is linear in 1/C_xr, fitted on the sets' measured stiffnesses; outside their
    range the line is extended, not measured, and a curvature or a regime change (a different
    compound, a studded set) would not show in the interval.

    Parameters
    ----------
    c_xr : float
        Stiffness of the set predicted for.
    fleet_c_xr : array_like
        Measured C_xr of the fleet's sets that inform the prediction.
    what : str
        Those sets in words, for the note.

    Returns
    -------
    dict
        ``extrapolation`` (bool), ``c_xr_range`` ([min, max], or None without sets) and
        ``extrapolation_note`` (a sentence, or None inside the range).

    Examples
    --------
    >>> stiffness_extrapolation(500.0, [25.0, 40.0, 60.0])["extrapolation_note"]
    'C_xr 500 is outside the range of the fleet [25, 60] (8.3x its maximum): extrapolation'
    """
    x = np.asarray(fleet_c_xr, float).ravel()
    x = x[np.isfinite(x)]
    if x.size == 0:
        note = f"no measured C_xr in {what}: every C_xr is an extrapolation"
        return {"extrapolation": True, "c_xr_range": None, "extrapolation_note": note}
    lo, hi = float(x.min()), float(x.max())
    if lo <= c_xr <= hi:
        return {"extrapolation": False, "c_xr_range": [lo, hi], "extrapolation_note": None}
    factor = f"{c_xr / hi:.2g}x its maximum" if c_xr > hi else f"{lo / c_xr:.2g}x below its minimum"
    note = (
        f"C_xr {c_xr:.3g} is outside the range of {what} [{lo:.3g}, {hi:.3g}] ({factor}): "
        "extrapolation"
    )
    return {"extrapolation": True, "c_xr_range": [lo, hi], "extrapolation_note": note}


def derive_mu_min_snow(braking: pd.DataFrame | None = None) -> float:
    """Midpoint between summer and winter snow decelerations in the braking data.

    Parameters
    ----------
    braking : pandas.DataFrame, optional
        Table in the layout of ``braking_by_tyre_type.csv``; default the shipped copy.

    Returns
    -------
    float
        (lowest winter-set mean deceleration on snow + highest summer-set bound) / 2 [g = mu].
        A summer row without a distance but with the note "more than twice" the winter distance
        contributes v^2 / (2 g * 2 d_winter), an upper bound on its deceleration.

    Examples
    --------
    >>> round(derive_mu_min_snow(), 2)
    0.26
    """
    raw = load_braking_data() if braking is None else braking
    snow = raw[raw["surface"] == "snow"]
    winter, summer = [], []
    for _, r in snow.iterrows():
        v = r["speed_from_kmh"]
        if r["tyre_type"] == "winter" and np.isfinite(r["distance_m"]):
            winter.append(float(mean_deceleration_g(v, r["distance_m"])))
        elif r["tyre_type"] == "summer":
            if np.isfinite(r["distance_m"]):
                summer.append(float(mean_deceleration_g(v, r["distance_m"])))
            elif "more than twice" in str(r["note"]):
                same = snow[(snow["source"] == r["source"]) & (snow["tyre_type"] == "winter")]
                d = 2 * float(same["distance_m"].iloc[0])
                summer.append(float(mean_deceleration_g(v, d)))
    if not winter or not summer:
        raise BadInputError("braking data: expected winter and summer rows on snow, got too few")
    return 0.5 * (min(winter) + max(summer))


def cost_threshold(cost_false_alarm: float, cost_miss: float) -> float:
    """Probability above which warning has the lower expected cost: c_fa / (c_fa + c_miss).

    Examples
    --------
    >>> cost_threshold(1.0, 9.0)
    0.1
    """
    if not (cost_false_alarm > 0 and cost_miss > 0):
        raise BadInputError(
            f"costs: expected positive false-alarm and miss costs, got {cost_false_alarm}, "
            f"{cost_miss}"
        )
    return cost_false_alarm / (cost_false_alarm + cost_miss)


def winter_verdict(
    mu_draws,
    *,
    mu_min: float = DEFAULT_MU_MIN_SNOW,
    cost_false_alarm: float = DEFAULT_COST_FALSE_ALARM,
    cost_miss: float = DEFAULT_COST_MISS,
    straddle_tol: float = DEFAULT_STRADDLE_TOL,
) -> WinterVerdict:
    """Verdict on a set's winter suitability from predictive draws of its snow friction.

    Parameters
    ----------
    mu_draws : array_like
        Predictive draws of mu on snow (e.g. from ``predict_friction(..., surface="snow")``).
    mu_min : float
        Minimum acceptable mu on snow (default :data:`DEFAULT_MU_MIN_SNOW`).
    cost_false_alarm, cost_miss : float
        Relative costs; the probability threshold is ``c_fa / (c_fa + c_miss)``.
    straddle_tol : float
        Reach of the 90 % interval past ``mu_min`` on both sides that makes the evidence
        insufficient.

    Returns
    -------
    WinterVerdict
        ``verdict`` ("ok", "warn", "insufficient_evidence"), ``probability`` (P(mu < mu_min)),
        ``threshold``, ``mu_min``, ``mu`` (summary), ``interval_90`` (central), ``costs``,
        ``straddle_tol``, ``n_draws``, ``reason`` (one sentence); ``to_dict()`` for JSON.

    Examples
    --------
    >>> winter_verdict(np.random.default_rng(0).normal(0.45, 0.03, 4000)).verdict
    'ok'
    """
    x = np.asarray(mu_draws, float).ravel()
    x = x[np.isfinite(x)]
    if x.size < 10:
        raise BadInputError(f"verdict: expected at least 10 finite draws, got {x.size}")
    if not straddle_tol >= 0:
        raise BadInputError(f"straddle_tol: expected >= 0, got {straddle_tol}")
    mu_min = check_mu_min(mu_min)
    threshold = cost_threshold(cost_false_alarm, cost_miss)
    p = float(np.mean(x < mu_min))
    lo, hi = (float(q) for q in np.quantile(x, [0.05, 0.95]))
    reach = min(mu_min - lo, hi - mu_min)
    if reach > straddle_tol:
        verdict = "insufficient_evidence"
        reason = (
            f"90% interval [{lo:.2f}, {hi:.2f}] reaches more than {straddle_tol:.2f} below and "
            f"above mu_min {mu_min:.2f}: the data cannot tell"
        )
    elif p > threshold:
        verdict = "warn"
        reason = f"P(mu < {mu_min:.2f}) = {p:.3f} exceeds the cost threshold {threshold:.3f}"
    else:
        verdict = "ok"
        reason = f"P(mu < {mu_min:.2f}) = {p:.3f} is within the cost threshold {threshold:.3f}"
    return WinterVerdict(
        verdict=verdict,
        probability=p,
        threshold=threshold,
        mu_min=float(mu_min),
        mu=summarize(x).to_dict(),
        interval_90=[lo, hi],
        costs={"false_alarm": float(cost_false_alarm), "miss": float(cost_miss)},
        straddle_tol=float(straddle_tol),
        n_draws=int(x.size),
        reason=reason,
    )


def high_wear_warning(
    ratio_draws: np.ndarray, threshold: float = 1.25, decision_probability: float = 0.8
) -> WearWarning:
    """Warn "unexpectedly high wear" when P(I_now / I_ref > threshold) >= decision_probability.

    Parameters
    ----------
    ratio_draws : ndarray
        Posterior draws of the wear rate now over the reference rate, I_now / I_ref [-].
    threshold : float
        Ratio above which the wear counts as unexpectedly high [-].
    decision_probability : float
        Posterior probability of exceeding ``threshold`` that raises the warning [-].

    Returns
    -------
    WearWarning
        ``warning``, ``probability``, ``threshold`` and a one-line ``message``.

    Examples
    --------
    >>> draws = np.random.default_rng(0).normal(1.5, 0.1, 2000)
    >>> high_wear_warning(draws).message
    'unexpectedly high wear: P(wear rate > 1.25 x reference) = 0.99'
    """
    p = float(np.mean(np.asarray(ratio_draws) > threshold))
    warn = p >= decision_probability
    msg = (
        f"unexpectedly high wear: P(wear rate > {threshold:.2f} x reference) = {p:.2f}"
        if warn
        else f"no wear warning: P(wear rate > {threshold:.2f} x reference) = {p:.2f}"
    )
    return WearWarning(warning=warn, probability=p, threshold=threshold, message=msg)
