"""Abrasability γ (and κ) from one car's drive history: radius drift and optional tread readings.

Model (drive interval j, axle a, tyre pair p, tyre-set segment s)::

    log γ ~ Normal(log gamma_median, gamma_log_sd)        (WearPriors)
    log s ~ Normal(0, WORK_SCALE_LOG_SD)                   scale error of the longitudinal work
    log q_a ~ Normal(0, σ_q), corr LATERAL_AXLE_CORRELATION  scale error of the lateral work,
                                                          σ_q the cornering stiffness' log-sd
                                                          (W_y ∝ 1 / c_y; history.lateral_log_sd)
    κ     ~ Normal(0, kappa_sd)                            extended model; 0 in the baseline
    Δ_j,a = γ exp(κ (T_j,a − 20)) (s Wx_j,a + q_a Wy_j,a) / 2 / A_wear
                                                          tread lost per tyre [mm] (eq. 4.26
                                                          with eq. 4.19a + b)
    y_k   = c_s − λ Σ_{j<k, j in s} (Δ_j,front − Δ_j,rear) + e_k
          (front/rear radius ratio in mm; c_s the set's unknown offset, marginalised under a
          Normal(segment mean, offset_sd_mm); e_k ~ N(0, σ_y² + sd_k²))
    W_j,a ~ N(Ŵ_j,a, sd_j,a² + τ² Ŵ_j,a²)                 the work's error and how well the drive
                                                          stands for its interval, marginalised:
                                                          y of a segment is multivariate normal
    depth_i ~ N(d0_p − Σ_j A_i,j,a Δ_j,a, σ_depth²)        readings (optional), σ_depth ~ LogNormal
                                                          (log 0.3 mm, 0.7); d0_p ~ N(8, 0.5),
                                                          integrated out, drawn after the chains

λ = 1 (the radius shrinks by the depth lost). The data fix γ s (``gamma_work``, wear per joule of
the evidence's longitudinal work) and the lateral work's ratios q_a / s; the model samples
u = log γ s and r_a = log q_a / s from their joint normal prior (all priors are normal in the
logs), and log s is drawn after the chains from its exact conditional given (u, r) (it enters
nothing else), which gives the posterior of γ itself and of q_a (``lateral_work_scale``). The
rear axle of a front-driven car has almost no longitudinal work: its wear rate is γ q_r Wy.
:func:`fit_wear_history` returns the package's
:class:`~tyrebayes.inference.result.Fit` (kind ``"wear_history"``) with the predictions of
:func:`~tyrebayes.inference.wear.history_predict.wear_history_predictions` in its attributes.
"""

from __future__ import annotations

import dataclasses
import json

import arviz_base as azb
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import numpyro
import numpyro.distributions as dist

from ...physics.wear import TreadGeometry
from ..nuts import run_nuts
from ..result import Fit, diagnose, provenance
from .change_readings import classify_changes_by_readings
from .data import WearPriors
from .history import DriveHistory, TreadReadings, reading_exposure

#: Log-sd of the scale error of a stream's longitudinal friction work (eq. 4.19a from smoothed
#: F_x and σ_x, the radius-ratio correction of the slip, the brush slip under braking). Nothing
#: in a stream measures this scale: γ = (γ s) / s, so its prior bounds γ's interval from below
#: (a 90 % half-width of about 1.645 × 0.12 = 0.20 in the log however much the readings say).
#: It is what the evidence can get wrong on a real car (brake balance, radius ratios, the
#: force balance's gain), not fitted to the drive-history simulator, where
#: ``benchmarks/results/wear_history.json`` (``evidence_work_over_true``) reports the ratio.
WORK_SCALE_LOG_SD = 0.12
#: Correlation of the front and rear lateral-work scale errors: both axles carry the same tyre
#: model, so most of an error in c_y is common; the axles differ in compliance steer and load.
LATERAL_AXLE_CORRELATION = 0.75
#: Prior sd of a tyre set's radius-ratio offset [mm]: manufacturing spread of four tyres and
#: fitting, far wider than what a set's drives leave (effectively flat).
OFFSET_SD_MM = 3.0
#: Prior scale of the drive-to-drive ratio noise beyond the stated sd [mm] (pressure, load and
#: temperature move the rolling radius by tenths of a per mille between drives).
RATIO_NOISE_SCALE_MM = 0.1
#: Prior scale of τ, how much an interval's friction work differs from its logged drive's [-].
REPRESENTATIVENESS_SCALE = 0.3
#: Log-sd of a tread reading's noise about its median (WearPriors.depth_noise_scale_mm): 90 % in
#: 0.3 / 3.2 to 0.3 × 3.2 mm. A reading is a gauge's resolution plus where on the tread it was
#: taken: tenths of a millimetre, never hundredths. A half-normal prior, with the few readings of a
#: year, let the noise approach zero, where the readings fix the wear exactly: a funnel in which
#: NUTS diverged on simulated years (``benchmarks/wear_history.py``).
DEPTH_NOISE_LOG_SD = 0.7
#: Depth of a new tyre and its spread [mm] (a history starts on new tyres unless readings say
#: otherwise; replacements fit new tyres).
NEW_DEPTH_MM, NEW_DEPTH_SD_MM = 8.0, 0.5


def _segment_blocks(history: DriveHistory) -> list[np.ndarray]:
    return [np.nonzero(history.segment == s)[0] for s in np.unique(history.segment)]


def wear_history_model(
    history: DriveHistory,
    exposure: np.ndarray | jax.Array | None,
    read_pair: np.ndarray | jax.Array | None,
    depth_mm: np.ndarray | jax.Array | None,
    extended: bool,
    priors: WearPriors,
    wear_area_mm2: float,
):
    """The NumPyro model of the module docstring (static shapes; segments unrolled)."""
    scales = _ScalePrior.of(priors, history.lateral_log_sd)
    prior_sd = float(np.sqrt(scales.cov_y[0, 0]))
    log_gw = numpyro.sample(
        "log_gamma_work", dist.Normal(np.log(priors.gamma_median_mm3_per_j), prior_sd)
    )
    gamma = numpyro.deterministic("gamma_work", jnp.exp(log_gw))
    # r | u (constant covariance, non-centred: rank-deficient without lateral uncertainty)
    z = numpyro.sample("lateral_z", dist.Normal(0.0, 1.0).expand([2]).to_event(1))
    u_dev = log_gw - np.log(priors.gamma_median_mm3_per_j)
    log_ratio = numpyro.deterministic(
        "log_lateral_ratio", jnp.asarray(scales.r_given_u) * u_dev + jnp.asarray(scales.r_root) @ z
    )
    kappa = numpyro.sample("kappa", dist.Normal(0.0, priors.kappa_sd_per_k)) if extended else 0.0
    sigma_y = numpyro.sample("sigma_ratio_mm", dist.HalfNormal(RATIO_NOISE_SCALE_MM))
    tau = numpyro.sample("tau", dist.HalfNormal(REPRESENTATIVENESS_SCALE))
    # (n, 2): each axle's tyres wear at their own temperature
    factor = gamma * jnp.exp(kappa * (history.tyre_temperature_c - 20.0)) / 2.0 / wear_area_mm2
    work = jnp.asarray(history.work_j) + jnp.exp(log_ratio)[None, :] * jnp.asarray(
        history.work_y_j
    )  # per joule of longitudinal evidence work
    loss = factor * work  # (n, 2) mm per tyre
    diff = loss[:, 0] - loss[:, 1]
    var_w = jnp.asarray(history.work_sd_j) ** 2 + (tau * work) ** 2
    var_diff = jnp.sum(factor**2 * var_w, axis=1)
    for s, idx in enumerate(_segment_blocks(history)):
        m = idx.size
        lower = np.tril(np.ones((m, m)), -1)  # y_k sees intervals j < k
        mean = -lower @ diff[idx]
        y = history.ratio_mm[idx]
        cov = (
            (lower * var_diff[idx][None, :]) @ lower.T
            + jnp.diag(sigma_y**2 + history.ratio_sd_mm[idx] ** 2)
            + OFFSET_SD_MM**2
        )
        numpyro.sample(
            f"ratio_{s}",
            dist.MultivariateNormal(mean + float(np.mean(y)), covariance_matrix=cov),
            obs=y,
        )
    if depth_mm is not None:
        sigma_d = numpyro.sample(
            "sigma_depth_mm",
            dist.LogNormal(np.log(priors.depth_noise_scale_mm), DEPTH_NOISE_LOG_SD),
        )
        lost = jnp.einsum("mja,ja->m", exposure, loss)
        # The pairs' initial depths d0_p are integrated out (readings of one pair share theirs):
        # they are Normal given everything else, so NUTS need not explore them, and their
        # posterior is drawn exactly after the chains (_initial_depths).
        pair = jnp.asarray(read_pair)
        same = (pair[:, None] == pair[None, :]).astype(lost.dtype)
        cov = NEW_DEPTH_SD_MM**2 * same + sigma_d**2 * jnp.eye(pair.shape[0], dtype=lost.dtype)
        numpyro.sample(
            "depth",
            dist.MultivariateNormal(NEW_DEPTH_MM - lost, covariance_matrix=cov),
            obs=depth_mm,
        )


class _ScalePrior(eqx.Module):
    """The joint normal prior of x = (log γ, log s, log q_f, log q_r) and of y = (u, r_f, r_r).

    y = A x with u = log γ + log s and r_a = log q_a − log s. ``cov_y`` (3, 3); ``r_given_u``
    (2,) and ``r_root`` (2, 2): r | u = r_given_u (u − μ) + r_root z, z ~ N(0, I);
    ``s_given_y`` (3,) and ``s_sd``: log s | y = s_given_y · (y − E y) + s_sd N(0, 1).
    """

    cov_y: np.ndarray
    r_given_u: np.ndarray
    r_root: np.ndarray
    s_given_y: np.ndarray
    s_sd: float

    @classmethod
    def of(cls, priors: WearPriors, lateral_log_sd: float) -> _ScalePrior:
        sq, rho = float(lateral_log_sd), LATERAL_AXLE_CORRELATION
        cov_x = np.zeros((4, 4))
        cov_x[0, 0], cov_x[1, 1] = priors.gamma_log_sd**2, WORK_SCALE_LOG_SD**2
        cov_x[2:, 2:] = sq**2 * np.array([[1.0, rho], [rho, 1.0]])
        a = np.array([[1.0, 1.0, 0.0, 0.0], [0.0, -1.0, 1.0, 0.0], [0.0, -1.0, 0.0, 1.0]])
        cov_y = a @ cov_x @ a.T
        r_given_u = cov_y[1:, 0] / cov_y[0, 0]
        r_cov = cov_y[1:, 1:] - np.outer(cov_y[1:, 0], cov_y[0, 1:]) / cov_y[0, 0]
        vals, vecs = np.linalg.eigh(r_cov)
        r_root = vecs * np.sqrt(np.clip(vals, 0.0, None))[None, :]
        cov_sy = (cov_x @ a.T)[1]  # cov(log s, y)
        s_given_y = cov_sy @ np.linalg.pinv(cov_y, hermitian=True)
        s_var = max(cov_x[1, 1] - float(s_given_y @ cov_sy), 0.0)
        return cls(cov_y, r_given_u, r_root, s_given_y, float(np.sqrt(s_var)))


def _split_work_scale(
    log_gw: np.ndarray, log_ratio: np.ndarray, priors: WearPriors, lateral_log_sd: float, seed: int
) -> dict:
    """γ, s and q_a from draws of u = log γ s and r_a = log q_a / s (module docstring)."""
    scales = _ScalePrior.of(priors, lateral_log_sd)
    dev = np.concatenate(
        [(log_gw - np.log(priors.gamma_median_mm3_per_j))[..., None], log_ratio], axis=-1
    )
    rng = np.random.default_rng(seed + 7919)
    log_s = dev @ scales.s_given_y + scales.s_sd * rng.standard_normal(log_gw.shape)
    return {
        "gamma": np.exp(log_gw - log_s),
        "work_scale": np.exp(log_s),
        "lateral_work_scale": np.exp(log_ratio + log_s[..., None]),
    }


def _init_values(priors: WearPriors, extended: bool, n_pairs: int | None) -> dict:
    """NUTS's start: γ at its prior median, small noise scales, κ = 0 where inferred, and each
    tyre pair new (``n_pairs``: with readings; None without, when depths are not sampled)."""
    init = {
        "log_gamma_work": np.log(priors.gamma_median_mm3_per_j),
        "sigma_ratio_mm": 0.02,
        "tau": 0.1,
        "lateral_z": np.zeros(2),
    }
    if extended:
        init["kappa"] = 0.0
    if n_pairs is not None:
        init["sigma_depth_mm"] = 0.2
    return init


def tread_loss(history, gamma, kappa, log_ratio, wear_area_mm2: float) -> np.ndarray:
    """Tread lost per draw, drive and axle position (..., n, 2) [mm per tyre].

    γ exp(κ (T − 20)) per joule of each drive's work, longitudinal plus lateral at the scale
    exp(``log_ratio``) = q_a / s (eq. 4.19a + b), over the two tyres' wear area. ``gamma`` and
    ``kappa`` have the draws' shape, ``log_ratio`` that shape and 2.
    """
    warm = np.exp(np.asarray(kappa)[..., None, None] * (history.tyre_temperature_c - 20.0))
    factor = np.asarray(gamma)[..., None, None] * warm / 2.0 / wear_area_mm2  # (..., n, 2)
    work = history.work_j + np.exp(np.asarray(log_ratio))[..., None, :] * history.work_y_j
    return factor * work


def _initial_depths(
    samples, history, exposure, read_pair, depth, wear_area_mm2, seed
) -> np.ndarray:
    """Draws of each pair's initial depth d0_p from its exact conditional given a draw's other
    parameters and the readings (the model integrates it out): Normal, by conjugacy, with
    precision 1/0.5² + n_p/σ_depth² and mean its precision-weighted prior and readings
    (reading + the depth the history wore off by it). Shape (chains, draws, pairs)."""
    gamma = np.asarray(samples["gamma_work"])
    kappa = np.asarray(samples.get("kappa", np.zeros_like(gamma)))
    loss = tread_loss(history, gamma, kappa, samples["log_lateral_ratio"], wear_area_mm2)
    lost = np.einsum("mja,cdja->cdm", exposure, loss)
    sigma = np.asarray(samples["sigma_depth_mm"])
    seen = depth + lost  # each reading's initial depth, in the reading's noise
    onehot = np.asarray(read_pair)[:, None] == np.arange(history.n_pairs)[None, :]  # (m, p)
    precision = 1.0 / NEW_DEPTH_SD_MM**2 + onehot.sum(axis=0) / sigma[..., None] ** 2
    mean = (NEW_DEPTH_MM / NEW_DEPTH_SD_MM**2 + (seen @ onehot) / sigma[..., None] ** 2) / precision
    rng = np.random.default_rng(seed + 1)
    return mean + rng.standard_normal(mean.shape) / np.sqrt(precision)


def _history_attrs(history: DriveHistory, extended: bool) -> dict:
    """The fit file's attributes from the history: its tyre changes (JSON), the model, and the
    cornering stiffness' source and log-sd behind the lateral work."""
    changes = history.changes
    return {
        "tyre_changes": json.dumps(
            {
                "drive_index": changes.index.tolist(),
                "change_type": list(changes.change_type),
                "probability": changes.probability.tolist(),
                "statistic": changes.statistic.tolist(),
                "threshold": changes.threshold,
                "false_alarm_rate": changes.false_alarm_rate,
            }
        ),
        "model": "extended" if extended else "baseline",
        "lateral_source": history.lateral_source,
        "lateral_log_sd": float(history.lateral_log_sd),
        "history_end_km": history.end_km,
    }


@dataclasses.dataclass(frozen=True)
class _Sampling:
    """One NUTS run of the history model and its diagnostics, at a number of draws and a seed:
    :func:`fit_wear_history` runs it once, and once more where the draws fell short."""

    args: tuple  # wear_history_model's
    init: dict
    num_warmup: int
    num_chains: int

    def __call__(self, samples_per_chain: int, run_seed: int):
        history, exposure, read_pair, depth, extended, priors, wear_area = self.args
        draws = run_nuts(
            wear_history_model,
            self.args,
            seed=run_seed,
            num_warmup=self.num_warmup,
            num_samples=samples_per_chain,
            num_chains=self.num_chains,
            init_values=self.init,
            static_argnums=(0,),  # the drives' segments shape the model
            target_accept_prob=0.95,
        )
        samples = dict(draws.samples)
        samples.update(
            _split_work_scale(
                samples["log_gamma_work"],
                samples["log_lateral_ratio"],
                priors,
                history.lateral_log_sd,
                run_seed,
            )
        )
        if depth is not None:
            samples["initial_depth_mm"] = _initial_depths(
                samples, history, exposure, read_pair, depth, wear_area, run_seed
            )
        tree = azb.from_dict({"posterior": samples, "sample_stats": {"diverging": draws.diverging}})
        tree.attrs.update(_history_attrs(history, extended))
        names = ["log_gamma_work", "lateral_z", "sigma_ratio_mm", "tau"]
        names += ["kappa"] if extended else []
        return tree, diagnose(tree, method="nuts", var_names=names)


def fit_wear_history(
    history: DriveHistory,
    readings: TreadReadings | None = None,
    *,
    extended: bool = True,
    num_warmup: int = 500,
    num_samples: int = 500,
    num_chains: int = 2,
    seed: int = 0,
    priors: WearPriors | None = None,
    geom: TreadGeometry | None = None,
    source: str = "drive history",
) -> Fit:
    """Posterior of γ (and κ) from a :class:`DriveHistory` by NUTS (module docstring).

    Parameters
    ----------
    history : DriveHistory
        From :func:`~tyrebayes.inference.wear.history.drive_history`.
    readings : TreadReadings, optional
        Tread-depth readings; without them only the radius drift informs γ.
    extended : bool
        Infer the temperature sensitivity κ of γ (the package's extended wear model).
    num_warmup, num_samples, num_chains, seed
        NUTS settings.
    priors : WearPriors, optional
    geom : TreadGeometry, optional
        Tread band (wear area, R_0).
    source : str
        Provenance.

    Returns
    -------
    Fit
        ``kind="wear_history"``, fitted to the history through its latest tread reading
        (:meth:`~tyrebayes.inference.wear.history.DriveHistory.through`; ``history_end_km``
        in its attributes) and with its tyre changes' types given the readings too
        (:func:`~tyrebayes.inference.wear.change_readings.classify_changes_by_readings`;
        ``tyre_changes`` in its attributes); diagnostics by
        :func:`~tyrebayes.inference.result.diagnose` over log γ s, σ_ratio, τ (and κ); a run
        short only of effective draws (:attr:`.Diagnostics.short_of_draws`) is run again with
        twice ``num_samples`` (the provenance says how many);
        ``gamma``, ``work_scale`` and ``lateral_work_scale`` (front, rear) are drawn after the
        chains (module docstring). ``data.attrs`` holds the history's tyre changes and the
        cornering stiffness' source.

    Examples
    --------
    >>> history = drive_history(wear_evidence_table(paths, vehicle))  # doctest: +SKIP
    >>> fit = fit_wear_history(history, tread_readings(readings_table))  # doctest: +SKIP
    >>> fit.kind, fit.converged  # doctest: +SKIP
    ('wear_history', True)
    """
    priors = WearPriors() if priors is None else priors
    geom = TreadGeometry() if geom is None else geom
    exposure = read_pair = depth = None
    if readings is not None and readings.depth_mm.size:
        history = classify_changes_by_readings(
            history.through(float(np.max(readings.odometer_km))),
            readings,
            new_depth_mm=NEW_DEPTH_MM,
            new_depth_sd_mm=NEW_DEPTH_SD_MM,
            wear_area_mm2=float(geom.wear_area_mm2),
            priors=priors,
        )
        exposure, read_pair = reading_exposure(history, readings)
        depth = np.asarray(readings.depth_mm)
    args = (history, exposure, read_pair, depth, extended, priors, float(geom.wear_area_mm2))
    init = _init_values(priors, extended, history.n_pairs if depth is not None else None)

    sample = _Sampling(args, init, num_warmup, num_chains)
    tree, diagnostics = sample(num_samples, seed)
    if diagnostics.short_of_draws:
        # Chains that agree and did not diverge but mix slowly: one more run with twice the
        # draws per chain.
        num_samples *= 2
        tree, diagnostics = sample(num_samples, seed + 1)
    return Fit(
        data=tree,
        diagnostics=diagnostics,
        kind="wear_history",
        provenance=provenance(
            "nuts",
            "extended" if extended else "baseline",
            (source,),
            seed=seed,
            num_warmup=num_warmup,
            num_samples=num_samples,
            num_chains=num_chains,
            n_drives=history.n_drives,
            n_readings=0 if depth is None else int(depth.size),
        ),
    )
