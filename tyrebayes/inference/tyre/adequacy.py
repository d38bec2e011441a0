"""Does the fitted per-tyre model describe the drive? Model adequacy, returned as data.

A sampler can converge on a model that does not describe the data: its posterior is then precise
and wrong. Beside ``converged`` every tyre fit carries :class:`Adequacy`, computed from the
standardised slip residuals z = (σ_obs − E[σ | ρ_obs]) / sd at the posterior mean, window by
window, with these checks (each a reason when it fails):

* **correlated errors**: the batch-means variance inflation of z (:mod:`.window_correlation`)
  above :data:`MAX_VARIANCE_INFLATION`. The features' smoothing alone makes it about 2.3 on the
  package's simulated drives; far above that the slip errors wander over tens of seconds (a slip
  offset that jumps, a radius that changes, a force error that drifts), which the model's single
  offset per drive does not describe. The fit already counts each window at 1/inflation, so its
  intervals widen, but its centre can be off.
* **predictive misfit**: the share of slip windows outside the 90 % predictive band (|z| >
  1.645) above :data:`MAX_OUTSIDE_90`: the model's noise does not describe the residuals.
* **residual trend against force**: a least-squares line of z on the window force with a slope
  whose t-value, deflated by √inflation, exceeds :data:`MAX_TREND_T`: the curve's shape is wrong
  over the range the drive used.
* **a step in the slip offset**: the mean slip residual of each 5 s block, split at the point
  that separates them most, with a t-value above :data:`MAX_STEP_T` (the blocks' spread read
  from their successive differences, robustly, so that the step itself does not widen it) and a
  size above :data:`MIN_STEP_SLIP`: a tyre changed, a radius jumped (puncture, pressure loss), or
  a wheel-speed sensor was swapped within the drive; slow drift does not pass both.
* **curve shape at the edge of the measured tyres**: the Magic Formula shape or curvature more
  than :data:`MAX_SHAPE_PRIOR_SDS` prior sds from the measured tyres' mean.

Two checks ask instead whether the drive identifies C_x at all:

* **too little excitation**: fewer than :data:`MIN_EXCITED_WINDOWS` slip windows with
  |ρ_x| ≥ :data:`EXCITATION_FORCE`. C_x is the slope of slip on force; where every window's force
  stays within the force noise (cruising), the model can explain the forces' spread as true
  force under a small noise scale and the slips' as noise, and then reports a slope that no
  force change measured, with an interval that looks like a real one (ten minutes at constant
  speed with an external drive's sensor noise gave C_x 195 ± 48 where that car's tyre has 48.7:
  ``benchmarks/results/identification.json``).
* **C_xr far outside the type prior**: its posterior mean more than :data:`MAX_C_XR_PRIOR_SDS`
  prior sds (log scale) from the prior's median, a factor of 6 either way with the default
  log-sd 0.45: no tyre of the type has it, and a wrong wheel radius, driven axle, mass or unit
  is far likelier (the online estimator withholds its C_x at the same distance,
  :attr:`~tyrebayes.inference.online.OnlineConfig.max_prior_z`).

And one whether the drive's label fits what it measured:

* **μ_max far outside its surface's prior**: on a surface where the fit observed μ_max (ABS
  windows), its posterior mean more than :data:`MAX_MU_PRIOR_SDS` prior sds (log scale) from
  that surface's median: a dry road's 0.9 labelled ice (median 0.12, log-sd 0.4) is 5 sds out.
  The data then override the prior and the value is the drive's, but the label, which a fleet
  table groups μ by, is likely wrong.
* **μ_max likelier on a grippier surface**: the observed μ_max's log predictive density under
  the prior of a surface of higher median μ_max (its posterior sd added to the prior's) exceeds
  its label's by more than :data:`MAX_LABEL_LOG_BAYES_FACTOR`, a Bayes factor of 20, "strong"
  on Kass & Raftery's (1995) scale (:func:`likelier_surface`). The distance rule alone misses a
  neighbouring surface: a dry road's 0.91 labelled snow (median 0.35, log-sd 0.35) is 2.7 sds
  out, but 68 times likelier under the dry prior. Only grippier surfaces are weighed: the top of
  a surface's μ_max is the surface's (no tyre grips snow like a dry road), its bottom the tyre's.
  A summer tyre on snow sits far below the snow prior's median, which spans tyre types, and a
  worn one on a dry road below the dry one's; the ice and wet priors would "explain" those
  values better, and a label that is right would be doubted.

The fitted scales λ of the stream's stated slip and force noise do not decide it: the model
infers them, so a stream whose noise estimate is off is still described; the fit summary reports
them (``noise_scales``) so that a user sees how far off the stream's estimates were.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from .window_correlation import variance_inflation

MAX_VARIANCE_INFLATION = 4.0
MAX_OUTSIDE_90 = 0.2
MAX_TREND_T = 4.0
MAX_SHAPE_PRIOR_SDS = 2.5
MAX_STEP_T = 8.0
# Each side of a step needs this many blocks.
MIN_STEP_BLOCKS = 3
# A step in the slip offset smaller than this is a drift, not a change of tyre or radius [-]: 0.1 %
# of rolling radius, about a 0.3 bar pressure loss or a millimetre of tread; tyres warming over a
# drive move it by a few 1e-5 on the package's simulated drives.
MIN_STEP_SLIP = 1e-3
#: Force of a window that excites the tyre [-]: beyond the force noise (±0.01, the error budget
#: behind ``PUSHING_MARGIN``) five times over. The online estimator counts the same windows.
EXCITATION_FORCE = 0.05
#: Least number of exciting slip windows (5 s of them at 0.25 s windows) for a slope to be read.
MIN_EXCITED_WINDOWS = 20
#: Farthest posterior mean of log C_xr from the type prior's median, in prior sds.
MAX_C_XR_PRIOR_SDS = 4.0
#: Farthest posterior mean of an observed log μ_max from its surface's median, in prior sds.
MAX_MU_PRIOR_SDS = 4.0
#: Largest log Bayes factor [nats] of a grippier surface's μ_max prior over the label's for an
#: observed μ_max: 20, "strong evidence" (Kass & Raftery 1995, J. Am. Stat. Assoc. 90, 773).
MAX_LABEL_LOG_BAYES_FACTOR = float(np.log(20.0))


def likelier_surface(
    log_mu_mean,
    log_mu_sd,
    label: str,
    surfaces: tuple[str, ...],
    log_medians,
    log_sds,
):
    """The grippier surface whose μ_max prior best predicts an observed μ_max, and by how much.

    Only surfaces whose prior median μ_max lies above the label's are weighed (module
    docstring): a μ_max too high for its label is the surface's doing, one too low may be the
    tyre's.

    Parameters
    ----------
    log_mu_mean, log_mu_sd : float or array
        Posterior mean and sd of log μ_max.
    label : str
        The drive's surface label (one of ``surfaces``).
    surfaces : tuple of str
        The surfaces with a μ_max prior.
    log_medians, log_sds : array
        Per surface, the prior's log median and log-sd.

    Returns
    -------
    (int, float or array)
        Index in ``surfaces`` of the likeliest surface of higher median than the label, and its
        log Bayes factor over the label [nats]: the difference of log N(m; log median,
        √(s² + sd²)) between the two (the prior predictive of the posterior mean, the
        posterior's own sd added); −inf (and the label's index) where no surface's median is
        higher. Works on NumPy and JAX arrays alike (the online estimator calls it traced).

    Examples
    --------
    >>> import numpy as np
    >>> best, lbf = likelier_surface(np.log(0.91), 0.03, "snow", ("snow", "dry"),
    ...                              np.log([0.35, 1.0]), np.array([0.35, 0.15]))
    >>> int(best), round(float(lbf), 1)
    (1, 4.3)
    """
    label_index = surfaces.index(label)
    # NumPy for host values: a fit calls this eagerly, where every jnp operation would be a
    # small compiled program of its own (compiled again after a worker drops its programs).
    traced = any(isinstance(a, jax.Array) for a in (log_mu_mean, log_mu_sd, log_medians, log_sds))
    xp = jnp if traced else np
    log_medians = xp.asarray(log_medians)
    scale = xp.sqrt(xp.asarray(log_sds) ** 2 + xp.asarray(log_mu_sd) ** 2)
    z = (log_mu_mean - log_medians) / scale
    log_density = -0.5 * z**2 - xp.log(scale) - 0.5 * math.log(2.0 * math.pi)
    grippier = log_medians > log_medians[label_index]
    candidates = xp.where(grippier, log_density, -xp.inf)
    best = xp.where(xp.any(grippier), xp.argmax(candidates), label_index)
    return best, candidates[best] - log_density[label_index]


def label_in_doubt(prior_sds: float, label_log_bayes_factor: float) -> bool:
    """The surface label of an observed μ_max is in doubt (module docstring's two rules)."""
    return bool(
        abs(prior_sds) > MAX_MU_PRIOR_SDS or label_log_bayes_factor > MAX_LABEL_LOG_BAYES_FACTOR
    )


@dataclasses.dataclass(frozen=True)
class Adequacy:
    """Whether a fitted model describes its data, and why not.

    Attributes
    ----------
    adequate : bool
        True when no check failed.
    reasons : tuple of str
        One line per failed check (empty when adequate).
    variance_inflation : float
        Largest per-drive variance inflation of the standardised slip residuals [-].
    outside_90 : float
        Share of slip windows outside the 90 % predictive band [-].
    trend_t : float
        t-value of the residuals' slope against the window force, deflated by √inflation [-].
    step_t : float
        Largest t-value of a step in the blocks' slip offsets [-].
    excited_windows : int or None
        Slip windows with |ρ_x| ≥ :data:`EXCITATION_FORCE` (None in a fit saved before the
        count was kept).
    c_xr_prior_sds : float
        Posterior mean of log C_xr in type-prior sds from the prior's median [-] (NaN where
        not known).
    mu_prior_sds : dict of str to float
        Per surface where μ_max was observed, its posterior mean (log) in prior sds from the
        surface's median [-].
    mu_likelier_surface : dict of str to list
        Per surface where μ_max was observed, the grippier surface whose prior predicts it best
        and that one's log Bayes factor over the label [nats] (:func:`likelier_surface`; no
        entry on the grippiest surface; empty in a fit saved before it was kept).
    """

    adequate: bool
    reasons: tuple[str, ...]
    variance_inflation: float
    outside_90: float
    trend_t: float
    step_t: float
    excited_windows: int | None = None
    c_xr_prior_sds: float = float("nan")
    mu_prior_sds: dict[str, float] = dataclasses.field(default_factory=dict)
    mu_likelier_surface: dict[str, list] = dataclasses.field(default_factory=dict)

    @property
    def measures_c_x(self) -> bool:
        """False when the drive does not measure C_x (the two identification checks of the
        module docstring): its C_xr is then no tyre's, and a fleet table leaves it out."""
        excited = self.excited_windows is None or self.excited_windows >= MIN_EXCITED_WINDOWS
        return excited and not abs(self.c_xr_prior_sds) > MAX_C_XR_PRIOR_SDS

    def as_dict(self) -> dict:
        return {**dataclasses.asdict(self), "reasons": list(self.reasons)}

    @classmethod
    def from_dict(cls, d: dict) -> Adequacy:
        """The inverse of :meth:`as_dict` (a saved fit's record)."""
        return cls(**{**d, "reasons": tuple(d["reasons"])})


def assess_adequacy(
    z: np.ndarray,
    rho: np.ndarray,
    drive_index: np.ndarray,
    n_drives: int,
    *,
    shape_prior_sds: dict[str, float],
    block_offsets: tuple[np.ndarray, ...] = (),
    c_xr_prior_sds: float = float("nan"),
    mu_prior_sds: dict[str, float] | None = None,
    mu_likelier_surface: dict[str, tuple[str, float]] | None = None,
) -> Adequacy:
    """Run the checks of the module docstring on one fit's slip windows.

    Parameters
    ----------
    z : ndarray
        Standardised slip residuals of the slip windows, in time order within each drive [-].
    rho : ndarray
        Measured window force of the same windows [-].
    drive_index : ndarray of int
        Drive of each window.
    n_drives : int
        Number of drives.
    shape_prior_sds : dict of str to float
        Posterior mean of each curve-shape parameter in prior sds from the prior mean [-].
    block_offsets : tuple of ndarray
        Per drive, its blocks' mean slip residuals in time order [-].
    c_xr_prior_sds : float
        Posterior mean of log C_xr in type-prior sds from the prior's median [-] (NaN skips
        the check).
    mu_prior_sds : dict of str to float, optional
        Per surface where μ_max was observed, its posterior mean (log) in prior sds from the
        surface's median [-].
    mu_likelier_surface : dict of str to (str, float), optional
        Per surface where μ_max was observed, :func:`likelier_surface`'s surface (by name) and
        log Bayes factor.
    """
    mu_prior_sds = {s: float(v) for s, v in (mu_prior_sds or {}).items()}
    mu_likelier_surface = {
        s: [str(other), float(lbf)] for s, (other, lbf) in (mu_likelier_surface or {}).items()
    }
    z, rho = np.asarray(z, float), np.asarray(rho, float)
    finite = np.isfinite(z) & np.isfinite(rho)
    excited = int(np.count_nonzero(np.abs(rho[finite]) >= EXCITATION_FORCE))
    if not finite.all():
        return Adequacy(
            adequate=False,
            reasons=(f"{int((~finite).sum())} slip windows with non-finite residuals",),
            variance_inflation=float("nan"),
            outside_90=float("nan"),
            trend_t=float("nan"),
            step_t=float("nan"),
            excited_windows=excited,
            c_xr_prior_sds=float(c_xr_prior_sds),
            mu_prior_sds=mu_prior_sds,
            mu_likelier_surface=mu_likelier_surface,
        )
    reasons = _identification_reasons(excited, c_xr_prior_sds)
    reasons += _label_reasons(mu_prior_sds, mu_likelier_surface)
    inflation = max(
        (
            variance_inflation(z[drive_index == d])
            for d in range(n_drives)
            if (drive_index == d).any()
        ),
        default=1.0,
    )
    outside = float(np.mean(np.abs(z) > 1.645)) if z.size else 0.0
    trend_t = _trend_t(z, rho, inflation)
    step_t, step_size = max((offset_step(b) for b in block_offsets), default=(0.0, 0.0))
    reasons += _misfit_reasons(inflation, outside, trend_t, step_t, step_size)
    reasons += _shape_reasons(shape_prior_sds)
    return Adequacy(
        adequate=not reasons,
        reasons=tuple(reasons),
        variance_inflation=float(inflation),
        outside_90=outside,
        trend_t=trend_t,
        step_t=step_t,
        excited_windows=excited,
        c_xr_prior_sds=float(c_xr_prior_sds),
        mu_prior_sds=mu_prior_sds,
        mu_likelier_surface=mu_likelier_surface,
    )


def _identification_reasons(excited: int, c_xr_prior_sds: float) -> list[str]:
    """Reasons why the drive does not identify C_x (too little excitation, C_xr off the type)."""
    reasons = []
    if excited < MIN_EXCITED_WINDOWS:
        reasons.append(
            f"too little excitation: {excited} slip windows with |rho_x| >= "
            f"{EXCITATION_FORCE:g} (need {MIN_EXCITED_WINDOWS}): the forces stay within their "
            "noise, so the drive does not measure C_x"
        )
    if abs(c_xr_prior_sds) > MAX_C_XR_PRIOR_SDS:
        reasons.append(
            f"C_xr {c_xr_prior_sds:+.1f} prior sds from the tyre type's median (beyond "
            f"{MAX_C_XR_PRIOR_SDS:g}): no tyre of the type has it; check the vehicle's wheel "
            "radius, mass and driven axle, and the stream's units"
        )
    return reasons


def _label_reasons(
    mu_prior_sds: dict[str, float], mu_likelier_surface: dict[str, list]
) -> list[str]:
    """Reasons to doubt a surface label: μ_max far from its prior, or likelier on a grippier one."""
    reasons = []
    for surface, sds in mu_prior_sds.items():
        if abs(sds) > MAX_MU_PRIOR_SDS:
            reasons.append(
                f"mu_max on {surface} {sds:+.1f} prior sds from that surface's median (beyond "
                f"{MAX_MU_PRIOR_SDS:g}): check the drive's surface label"
            )
    for surface, (other, lbf) in mu_likelier_surface.items():
        if lbf > MAX_LABEL_LOG_BAYES_FACTOR and not abs(mu_prior_sds.get(surface, 0.0)) > (
            MAX_MU_PRIOR_SDS
        ):
            reasons.append(
                f"mu_max on {surface} {np.exp(lbf):.0f} times likelier under the {other} prior "
                f"than under {surface}'s (Bayes factor beyond "
                f"{np.exp(MAX_LABEL_LOG_BAYES_FACTOR):.0f}): check the drive's surface label"
            )
    return reasons


def _trend_t(z: np.ndarray, rho: np.ndarray, inflation: float) -> float:
    """t-value of the residuals' least-squares slope on the force, deflated by √inflation."""
    trend_t = 0.0
    if z.size > 10 and np.std(rho) > 0:
        x = rho - rho.mean()
        slope = np.sum(x * z) / np.sum(x * x)
        resid = z - z.mean() - slope * x
        se = np.sqrt(np.sum(resid**2) / (z.size - 2) / np.sum(x * x))
        trend_t = float(slope / se / np.sqrt(inflation))
    return trend_t


def _misfit_reasons(
    inflation: float, outside: float, trend_t: float, step_t: float, step_size: float
) -> list[str]:
    """Reasons why the residuals are not the model's: correlated, too wide, trending, stepping."""
    reasons = []
    if inflation > MAX_VARIANCE_INFLATION:
        reasons.append(
            f"slip errors correlated over many windows (variance inflation {inflation:.1f} > "
            f"{MAX_VARIANCE_INFLATION:g}): a slowly varying slip or force error the model does "
            "not describe"
        )
    if outside > MAX_OUTSIDE_90:
        reasons.append(
            f"{outside:.0%} of slip windows outside the 90 % predictive band "
            f"(> {MAX_OUTSIDE_90:.0%})"
        )
    if abs(trend_t) > MAX_TREND_T:
        reasons.append(
            f"slip residuals trend with the force (t = {trend_t:.1f}, |t| > {MAX_TREND_T:g}): the "
            "curve's shape does not fit the range of force the drive used"
        )
    if step_t > MAX_STEP_T and step_size > MIN_STEP_SLIP:
        reasons.append(
            f"the slip offset steps by {step_size:.4f} within the drive (t = {step_t:.1f}): a "
            "tyre, a rolling radius or a wheel-speed sensor changed"
        )
    return reasons


def _shape_reasons(shape_prior_sds: dict[str, float]) -> list[str]:
    """Reasons why the curve's shape is at the edge of the measured tyres'."""
    return [
        f"curve {name} {sds:+.1f} prior sds from the measured tyres' mean "
        f"(beyond {MAX_SHAPE_PRIOR_SDS:g})"
        for name, sds in shape_prior_sds.items()
        if abs(sds) > MAX_SHAPE_PRIOR_SDS
    ]


def offset_step(offsets: np.ndarray) -> tuple[float, float]:
    """The most significant single step in a sequence of block offsets: (t-value, size [-]).

    For each split with :data:`MIN_STEP_BLOCKS` blocks or more on each side, the difference of
    the two sides' means over its standard error; the blocks' sd is 1.4826·MAD of successive
    differences / √2, which one step barely moves. (0, 0) for too short a sequence.
    """
    b = np.asarray(offsets, float)
    b = b[np.isfinite(b)]
    n = b.size
    if n < 2 * MIN_STEP_BLOCKS:
        return 0.0, 0.0
    diffs = np.diff(b)
    scale = 1.4826 * np.median(np.abs(diffs - np.median(diffs))) / np.sqrt(2.0)
    if not scale > 0:
        return 0.0, 0.0
    k = np.arange(MIN_STEP_BLOCKS, n - MIN_STEP_BLOCKS + 1)
    cumulative = np.cumsum(b)
    step = (cumulative[-1] - cumulative[k - 1]) / (n - k) - cumulative[k - 1] / k
    t = np.abs(step) / (scale * np.sqrt(1.0 / k + 1.0 / (n - k)))
    best = int(np.argmax(t))
    return float(t[best]), float(abs(step[best]))


__all__ = [
    "EXCITATION_FORCE",
    "MAX_C_XR_PRIOR_SDS",
    "MAX_LABEL_LOG_BAYES_FACTOR",
    "MAX_MU_PRIOR_SDS",
    "MIN_EXCITED_WINDOWS",
    "Adequacy",
    "assess_adequacy",
    "label_in_doubt",
    "likelier_surface",
    "offset_step",
]
