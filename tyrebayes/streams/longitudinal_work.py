"""Longitudinal friction work of one drive per axle (thesis eq. 4.19a, 4.25, 4.27).

* **Longitudinal friction work** per axle, W_x = ∫ F_x V_x σ_x dt (eq. 4.19a, 4.25). On the
  driven axle in traction the slip is measured: the wheel speeds' σ_x, corrected for the drive's
  own per-wheel radius ratios (free rolling), times the force balance's F_x. Under braking the
  wheel speeds only see slip relative to the braking free wheels, and the free axle's slip is
  not seen at all, so there the linear slip σ_x = ρ_x / C_x of eq. 4.27 is used with the drive's
  own secant stiffness Ĉ_x = Σ ρ_x² F_z V dt / Σ F_x V σ_x dt over the driven axle's traction
  samples (both axles carry the same tyre model). Its uncertainty: the slip noise of every sample
  (correlated over the smoothing window), and the radius-ratio error, which multiplies the whole
  traction energy ∫ F_x V dt.
* **Braking split**: the features split a braking force by one fixed brake balance (0.7
  front). Coasting in gear is engine drag on the driven wheels alone, and a service brake with
  electronic brake-force distribution follows the axle loads, so the evidence re-splits each
  braking sample's total force: up to :data:`ENGINE_BRAKE_SHARE` of the weight on the driven
  axle(s), the rest in proportion to the axle loads (:func:`braking_split`). With the fixed
  balance the mild decelerations that dominate braking put too little force on the driven front
  axle and too much on the rear; the linear braking work goes with the force squared, so the
  front's braking work read low and the rear's, on the drive-history simulator, well above the
  truth.
* **The force's noise** (the force balance's F_x errs by a few hundred newtons, correlated only
  within the features' smoothing window) must neither choose the samples it is averaged over
  nor be squared. The free-rolling samples are chosen by |ρ_x| < 0.02: the samples whose noise
  pulled ρ_x into that window, so their own mean ρ_x reads the driven axle's free-rolling force
  near 0 (0.002 against a true 0.011 on a simulated commute), the free-rolling slip ρ_x / C_x
  is read as radius and taken off every traction sample's slip (σ_x 2·10⁻⁴ low, the measured
  traction work 7 % low). And ρ_x² of the kernel ρ_x² F_z V (eq. 4.27) carries the noise's
  variance, which inflates the traction kernel, hence Ĉ_x, by ~10 % and reads every linear
  (braking, free-axle) work low by as much. Both use the force just outside the window
  (:func:`_outside_window`), whose noise is independent of the sample's own. The kernel takes
  the noise's variance off: (ρ̂_x² − σ̂²) F_z V, with σ̂² from the second differences over k
  samples (:func:`_noise_variance`). The product ρ̂_x(t − k) ρ̂_x(t + k), also free of the
  noise, is not used: a force that changes within ±k samples (the onset of braking, an ABS
  stop) makes it smaller than ρ_x², and reads low the free rear axle's work, nearly all in
  such braking. The free-rolling force is the mean over those samples of the best linear
  predictor of the true ρ_x (:func:`_denoised_force`: regression calibration, with the true
  force's variance from the covariance over k samples).
* **Braking slip beyond linear**: σ_x = ρ_x / C_x (eq. 4.27) is the tyre's slope at zero slip;
  its curve bends, and harder braking slips more than linear (on the simulator the free rear
  axle's work, nearly all in braking, read 11 % low). The linear parts use the brush tyre's
  σ_x = g(ρ_x) ρ_x / C_x, g = 3 / (1 + a + a²), a = (1 − |ρ_x| / μ)^⅓, as the lateral work does
  (:func:`~tyrebayes.streams.lateral_work.brush_slip_angle`); g → 1 for small ρ_x, so Ĉ_x keeps
  its meaning. ``benchmarks/results/wear_history.json`` (``evidence_work_over_true``) measures
  what the three leave of the gap to the simulator's true work.

:func:`longitudinal_work` iterates the radius ratios and Ĉ_x (the ratios need Ĉ_x, Ĉ_x needs the
slip) and returns a :class:`LongitudinalWork`.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np

from ..physics.vehicle import GRAVITY_MPS2, Vehicle
from .features import StreamFeatures
from .lateral_work import LATERAL_MU
from .order_stats import median

#: Fewer samples than this in a group (braking, the rest) leave ρ̂_x² uncorrected.
_MIN_NOISE_SAMPLES = 50
#: The median of the χ² distribution with one degree of freedom.
_CHI2_1_MEDIAN = 0.4549364231195724

#: Coasting in gear brakes the driven wheels with the engine's drag, up to this share of the
#: weight (0.05 g, about 0.5 m/s²: a petrol car's deceleration in gear with the throttle shut).
ENGINE_BRAKE_SHARE = 0.05


def _window_step(feats: StreamFeatures) -> int:
    """k of :func:`_outside_window`: one more sample than the features' smoothing window."""
    return int(round(feats.smoothing_s * feats.sample_rate_hz)) + 1


def _outside_window(x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``x`` k samples before and after each sample (NaN past the ends). With k from
    :func:`_window_step` their noise is independent of the sample's own (module docstring),
    while a force changes little over k samples (0.3 s at 10 Hz)."""
    before = np.full_like(x, np.nan)
    after = np.full_like(x, np.nan)
    if x.shape[0] > k:
        before[k:] = x[:-k]
        after[:-k] = x[k:]
    return before, after


def _brush_factor(rho: np.ndarray, mu: float = LATERAL_MU) -> np.ndarray:
    """g(ρ_x) = 3 / (1 + a + a²), a = (1 − |ρ_x| / μ)^⅓: brush slip over linear slip (module
    docstring); |ρ_x| held below 0.97 μ as for the slip angle, NaN kept."""
    a = np.cbrt(1.0 - np.minimum(np.abs(rho), 0.97 * mu) / mu)
    return 3.0 / (1.0 + a + a * a)


def _free_slip_ratios(
    feats: StreamFeatures,
    driven: list[int],
    c_hat: float,
    free_force: dict[int, float] | None = None,
) -> np.ndarray:
    """Per-wheel radius ratios with the driven wheels' free-rolling slip taken out.

    "Free rolling" (|ρ_x| < 0.02 on the driven axle) still pushes against drag and rolling
    resistance, so the driven wheels turn faster by σ ≈ ρ_x / C_x there: the free-rolling ratio
    reads that slip as a smaller radius (the wheel turns faster as a smaller one would). Put
    back with the drive's secant stiffness (eq. 4.27): the ratio times 1 + ρ_x / Ĉ_x.
    ``free_force``: :func:`_free_rolling_force` of ``feats``, when the caller has it (it does
    not change with Ĉ_x, which :func:`longitudinal_work` iterates on).
    """
    ratio = np.asarray(feats.nuisances.radius_ratio, dtype=float).copy()
    if not (np.all(np.isfinite(ratio)) and np.isfinite(c_hat)):
        return ratio
    if free_force is None:
        free_force = _free_rolling_force(feats, driven)
    for axle in driven:
        ratio[2 * axle : 2 * axle + 2] *= 1.0 + np.nan_to_num(free_force[axle]) / c_hat
    return ratio


def _noise_variance(rho: np.ndarray, k: int, groups: np.ndarray) -> np.ndarray:
    """Per sample and axle, the variance of ρ̂_x's noise, one value per axle and group.

    The noise is independent past the smoothing window, so d = ρ̂_t − (ρ̂_t−k + ρ̂_t+k) / 2
    holds 1.5 times its variance, and the true force's part of d is negligible wherever the
    force is smooth over ±k samples: the median of d² over a group (robust to the braking onsets
    and ABS cycles, where it is not) is 0.455 × 1.5 σ² (the median of χ²₁ is 0.455). The groups
    are braking and the rest (:func:`_work_terms`): a braking split gives each axle its own
    share of the total force's noise. 0 for a group of fewer than :data:`_MIN_NOISE_SAMPLES`.
    """
    before, after = _outside_window(rho, k)
    d2 = (rho - 0.5 * (before + after)) ** 2
    out = np.zeros_like(rho)
    for axle in range(rho.shape[1]):
        for group in (True, False):
            rows = (groups == group) & np.isfinite(d2[:, axle])
            if rows.sum() >= _MIN_NOISE_SAMPLES:
                # np.median's, by one selection on the copy the mask makes (order_stats)
                middle = median(d2[rows, axle], overwrite_input=True)
                out[groups == group, axle] = middle / (1.5 * _CHI2_1_MEDIAN)
    return out


def _denoised_force(rho: np.ndarray, k: int) -> np.ndarray:
    """The best linear predictor of each sample's true ρ_x from its noisy one, per axle.

    E[ρ | ρ̂] = m + λ (ρ̂ − m), λ = cov(ρ̂_t, ρ̂_t+k) / var(ρ̂): the covariance over k samples
    (:func:`_outside_window`) is the true force's variance without the noise's. Averaged over
    samples chosen by ρ̂ it gives their true mean force (regression calibration), where ρ̂'s own
    mean there holds the noise that chose them.
    """
    out = np.array(rho, dtype=float)
    _, after = _outside_window(out, k)
    for axle in range(out.shape[1]):
        x, y = out[:, axle], after[:, axle]
        both = np.isfinite(x) & np.isfinite(y)
        if both.sum() < 3:
            continue
        m = float(np.mean(x[both]))
        var = float(np.var(x[both]))
        lam = float(np.mean((x[both] - m) * (y[both] - m)) / var) if var > 0 else 1.0
        out[:, axle] = m + float(np.clip(lam, 0.0, 1.0)) * (x - m)
    return out


def _free_rolling_force(feats: StreamFeatures, driven: list[int]) -> dict[int, float]:
    """Mean ρ_x of each driven axle over the straight free-rolling samples.

    The samples are chosen by their own noisy ρ_x, so the mean is of :func:`_denoised_force`
    (module docstring). 0 without such samples, NaN when none has a force
    (:func:`_free_slip_ratios` counts that as 0 too); found once per drive, also where the
    ratios turn out not to need it, so an all-NaN axle gives NaN without ``np.nanmean``'s
    warning.
    """
    free = feats.mask("free_rolling") & (np.abs(feats.steer_rad) < 0.02)
    rho = _denoised_force(feats.rho_axle, _window_step(feats))[free]
    if not rho.size:
        return dict.fromkeys(driven, 0.0)
    return {
        axle: float(np.nanmean(rho[:, axle])) if np.isfinite(rho[:, axle]).any() else np.nan
        for axle in driven
    }


def _corrected_slip(feats: StreamFeatures, ratio: np.ndarray, drive: str) -> np.ndarray:
    """Per-wheel slip with the drive's own radius ratios removed (NaN ratios: nominal radii).

    A wheel of true radius r_i R_nom reads wheel_vx_i = (1 + σ_i) V r_ref / r_i, where r_ref is
    the mean ratio of the wheels V_x comes from; hence σ_i = (1 + slip_i) r_i / r_ref − 1.
    """
    scale = _slip_scale(ratio, drive)
    if scale is None:
        return feats.slip
    return (1.0 + feats.slip) * scale[None, :] - 1.0


def _slip_scale(ratio: np.ndarray, drive: str) -> np.ndarray | None:
    """r_i / r_ref of :func:`_corrected_slip`, or None for nominal radii (a NaN ratio)."""
    if not np.all(np.isfinite(ratio)):
        return None
    ref = {"fwd": (2, 3), "rwd": (0, 1)}.get(drive, (0, 1, 2, 3))
    return ratio / float(np.mean(ratio[list(ref)]))


def _front_rear_ratio(ratio: np.ndarray, sd: np.ndarray) -> tuple[float, float]:
    front, rear = ratio[:2].mean(), ratio[2:].mean()
    # the four ratios share one normalisation; their errors are treated as independent
    value = front / rear
    value_sd = value * np.hypot(
        np.hypot(sd[0], sd[1]) / 2 / front, np.hypot(sd[2], sd[3]) / 2 / rear
    )
    return float(value), float(value_sd)


def braking_split(fx_axle_n: np.ndarray, fz_axle_n: np.ndarray, vehicle: Vehicle) -> np.ndarray:
    """Axle forces (n, 2) [N] with each braking sample's total re-split (module docstring).

    Where F_x,front + F_x,rear < 0: engine drag up to :data:`ENGINE_BRAKE_SHARE` m g on the
    driven axle(s) (split as the drive splits traction), the rest of the braking force in
    proportion to the axle loads (ideal, EBD-like distribution). Traction samples and NaN are
    kept as they are.

    Examples
    --------
    >>> from tyrebayes._domain import load_vehicle
    >>> car = load_vehicle("compact_fwd")
    >>> fx = braking_split(np.array([[-700.0, -300.0]]), np.array([[8000.0, 6000.0]]), car)
    >>> bool(fx[0, 0] < -700.0), float(fx.sum())
    (True, -1000.0)
    """
    fx = np.asarray(fx_axle_n, dtype=float)
    fz = np.asarray(fz_axle_n, dtype=float)
    total = fx[:, 0] + fx[:, 1]
    with np.errstate(invalid="ignore"):
        braking = total < 0.0
        engine = np.clip(total, -ENGINE_BRAKE_SHARE * vehicle.mass_kg * GRAVITY_MPS2, 0.0)
        load_share = fz[:, 0] / (fz[:, 0] + fz[:, 1])
    front = vehicle.traction_front_share * engine + load_share * (total - engine)
    split = np.column_stack([front, total - front])
    return np.where(braking[:, None], split, fx)


class _WorkTerms(eqx.Module):
    """What :func:`_longitudinal_work` needs that does not change with the radius ratios.

    Per sample and axle, shape (n, 2): ``power_w`` F_x V [W] (NaN where F_x is), ``usable``
    (valid, finite F_x, no spin), ``pushing`` (F_x > 0 on a driven axle), ``slip_sd`` [-],
    ``kernel_j`` ρ² g(ρ) F_z |V| dt [J], not yet masked: ρ² as ρ̂² less the noise's variance
    (:func:`_noise_variance`, in braking and elsewhere apart), so the force's noise does not
    add its variance, and g the brush factor (:func:`_brush_factor`).
    """

    power_w: np.ndarray
    usable: np.ndarray
    pushing: np.ndarray
    slip_sd: np.ndarray
    kernel_j: np.ndarray


#: Each axle's two wheels (front left, right; rear left, right) in the features' wheel order.
_AXLE_WHEELS = ((0, 1), (2, 3))


def _work_terms(feats, fx, is_driven, valid, dt) -> _WorkTerms:
    vx = feats.vx_mps
    fz = feats.fz_axle_n
    slip_axle_sd = np.column_stack(
        [np.hypot(feats.slip_sd[:, a], feats.slip_sd[:, b]) / 2 for a, b in _AXLE_WHEELS]
    )
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        rho = fx / fz
        braking = fx.sum(axis=1) < 0.0
        square = rho**2 - _noise_variance(rho, _window_step(feats), braking)
        return _WorkTerms(
            power_w=fx * vx[:, None],
            usable=valid[:, None] & np.isfinite(fx) & ~feats.spin[:, None],
            pushing=(fx > 0) & is_driven[None, :],
            slip_sd=slip_axle_sd,
            kernel_j=square * _brush_factor(rho) * fz * np.abs(vx)[:, None] * dt,
        )


class _MaskedSums(eqx.Module):
    """Every sum over samples that :func:`_longitudinal_work` needs, formed once per drive.

    The radius ratios move each wheel's slip affinely, σ_i = (1 + slip_i) s_i − 1 with
    s_i = r_i / r_ref (:func:`_corrected_slip`), and leave the usable samples as they are (a
    finite slip stays finite). So the measured traction work of an axle, Σ F_x V σ dt over
    its traction samples, is ½ Σ_i ((s_i − 1) E + s_i P_i) over its two wheels, from the sums
    E = Σ F_x V dt and P_i = Σ F_x V slip_i dt taken once: the iteration over the ratios in
    :func:`longitudinal_work` runs on these numbers, not on the samples.

    ``use`` (n, 2) the usable samples (valid, finite F_x and slip of both wheels, no spin),
    ``kernel_j`` (n, 2) ρ² F_z |V| dt there [J] (0 elsewhere); per axle ``noise_var_j2`` [J²],
    ``traction_energy_j`` E [J], ``linear_kernel_j`` [J] (the kernel of usable samples that do
    not push); per wheel ``slip_work_j`` P_i [J] (its axle's traction samples); and
    ``traction_kernel_j`` [J] in all.
    """

    use: np.ndarray
    kernel_j: np.ndarray
    noise_var_j2: np.ndarray
    traction_energy_j: np.ndarray
    linear_kernel_j: np.ndarray
    slip_work_j: np.ndarray
    traction_kernel_j: float


def _masked_sums(feats, terms: _WorkTerms, dt: float) -> _MaskedSums:
    slip = feats.slip
    finite_slip = np.isfinite(slip)
    use = terms.usable & np.column_stack(
        [finite_slip[:, a] & finite_slip[:, b] for a, b in _AXLE_WHEELS]
    )
    traction = use & terms.pushing
    power = np.where(traction, terms.power_w, 0.0)  # F_x V on the traction samples [W]
    # Slip noise is correlated over the smoothing window: a sum of n samples has the variance
    # of n / window independent ones, each window-fold larger.
    window = max(1.0, feats.smoothing_s * feats.sample_rate_hz)
    noise_var = np.where(traction, (power * terms.slip_sd) ** 2, 0.0).sum(axis=0) * dt**2 * window
    kernel = np.where(use, terms.kernel_j, 0.0)
    slip_work = np.array(
        [
            float(np.dot(power[:, axle], np.where(traction[:, axle], slip[:, wheel], 0.0))) * dt
            for axle, wheels in enumerate(_AXLE_WHEELS)
            for wheel in wheels
        ]
    )
    return _MaskedSums(
        use=use,
        kernel_j=kernel,
        noise_var_j2=noise_var,
        traction_energy_j=power.sum(axis=0) * dt,
        linear_kernel_j=np.where(use & ~traction, kernel, 0.0).sum(axis=0),
        slip_work_j=slip_work,
        traction_kernel_j=float(np.where(traction, kernel, 0.0).sum()),
    )


def _measured_work(sums: _MaskedSums, scale: np.ndarray | None) -> np.ndarray:
    """Σ F_x V σ dt of each axle's traction samples with the slip scaled by ``scale``
    (:func:`_slip_scale`; None: nominal radii), from the sums (:class:`_MaskedSums`)."""
    s = np.ones(4) if scale is None else scale
    energy = np.repeat(sums.traction_energy_j, 2)
    per_wheel = (s - 1.0) * energy + s * sums.slip_work_j
    return 0.5 * (per_wheel[0::2] + per_wheel[1::2])


def _longitudinal_work(ratios, ratio_sd4, drive, sums: _MaskedSums):
    """(work [J], its sd, Ĉ_x) of each axle at these radius ratios, from the sums."""
    measured = _measured_work(sums, _slip_scale(ratios, drive))
    noise_var, traction_kernel = sums.noise_var_j2, sums.traction_kernel_j
    _, ratio_sd = _front_rear_ratio(ratios, ratio_sd4)
    ratio_sd = ratio_sd if np.isfinite(ratio_sd) else 2e-3  # nominal radii: ~0.2 % unknown
    offset_var = (sums.traction_energy_j * ratio_sd) ** 2
    measured_total = float(measured.sum())
    measured_sd = float(np.sqrt(noise_var.sum() + offset_var.sum()))
    if measured_total > 0 and traction_kernel > 0:
        c_hat = float(traction_kernel / measured_total)
        rel_sd = measured_sd / measured_total
    else:
        c_hat, rel_sd = float("nan"), float("nan")
    linear_part = sums.linear_kernel_j
    linear = linear_part / c_hat if np.isfinite(c_hat) else np.zeros(2)
    work_x = measured + linear
    work_x_sd = np.sqrt(noise_var + offset_var + (linear * np.nan_to_num(rel_sd)) ** 2)
    return work_x, work_x_sd, c_hat


class LongitudinalWork(eqx.Module):
    """One drive's longitudinal friction work per axle (front, rear) and what it rests on.

    Attributes
    ----------
    work_x_j, work_x_sd_j : ndarray, shape (2,)
        Longitudinal friction work of each axle [J] and its standard error.
    secant_stiffness : float
        The drive's Ĉ_x [-] (NaN without traction samples).
    kernel_j : ndarray, shape (n, 2)
        ρ_x² F_z |V| dt of each usable sample and axle [J] (0 elsewhere).
    usable : ndarray, shape (n, 2)
        The samples that count (valid, finite F_x and slip, no spin).
    radius_ratio_front_rear, radius_ratio_front_rear_sd : float
        Front over rear rolling radius [-] (free-rolling slip taken out) and its standard error.

    Examples
    --------
    >>> from tyrebayes import load_vehicle, read_stream, validate_stream, compute_features
    >>> from tyrebayes._resources import data_dir
    >>> vehicle = load_vehicle("suv_rav4")
    >>> stream = validate_stream(read_stream(data_dir() / "comma2k19_rav4_segment.csv"), vehicle)
    >>> feats = compute_features(stream, vehicle)
    >>> work = longitudinal_work(feats, vehicle, feats.valid, 1.0 / feats.sample_rate_hz)
    >>> work.work_x_j.shape, work.weight_j.shape == feats.vx_mps.shape
    ((2,), True)
    """

    work_x_j: np.ndarray
    work_x_sd_j: np.ndarray
    secant_stiffness: float
    kernel_j: np.ndarray
    usable: np.ndarray
    radius_ratio_front_rear: float
    radius_ratio_front_rear_sd: float

    @property
    def weight_j(self) -> np.ndarray:
        """Per sample, both axles' kernel over the usable samples [J]: the friction weight."""
        return np.where(self.usable, self.kernel_j, 0.0).sum(axis=1)


def longitudinal_work(
    feats: StreamFeatures, vehicle: Vehicle, valid: np.ndarray, dt: float
) -> LongitudinalWork:
    """Longitudinal friction work per axle (module docstring), iterated with the radius ratios.

    The radius ratios need Ĉ_x (the driven wheels' free-rolling slip), Ĉ_x needs the slip the
    ratios correct: four rounds from nominal radii (NaN Ĉ_x).

    Parameters
    ----------
    feats : StreamFeatures
        The drive's features.
    vehicle : Vehicle
        The car (drive, brake-split geometry).
    valid : ndarray of bool, shape (n,)
        The samples that count (valid features with a finite V_x).
    dt : float
        Sample interval [s].

    Returns
    -------
    LongitudinalWork
    """
    driven = {"front": [0], "rear": [1], "both": [0, 1]}[vehicle.driven_axle]
    is_driven = np.zeros(2, dtype=bool)
    is_driven[driven] = True
    ratio_sd4 = np.asarray(feats.nuisances.radius_ratio_sd, dtype=float)
    c_hat = float("nan")
    fx_axle = braking_split(feats.fx_axle_n, feats.fz_axle_n, vehicle)
    sums = _masked_sums(feats, _work_terms(feats, fx_axle, is_driven, valid, dt), dt)
    free_force = _free_rolling_force(feats, driven)
    for _ in range(4):
        ratios = _free_slip_ratios(feats, driven, c_hat, free_force)
        work_x, work_x_sd, c_hat = _longitudinal_work(ratios, ratio_sd4, vehicle.drive, sums)
    ratio, ratio_sd = _front_rear_ratio(ratios, ratio_sd4)
    return LongitudinalWork(work_x, work_x_sd, c_hat, sums.kernel_j, sums.use, ratio, ratio_sd)
