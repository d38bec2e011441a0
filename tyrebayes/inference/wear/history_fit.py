"""Abrasability γ (and κ) from one car's drive history: radius drift and optional tread readings.

Model (drive interval j, axle a, tyre pair p, tyre-set segment s)::

    log γ ~ Normal(log gamma_median, gamma_log_sd)        (WearPriors)
    log s ~ Normal(0, WORK_SCALE_LOG_SD)                   scale error of the evidence's work
    κ     ~ Normal(0, kappa_sd)                            extended model; 0 in the baseline
    Δ_j,a = γ s exp(κ (T_j − 20)) W_j,a / 2 / A_wear      tread lost per tyre [mm] (eq. 4.26)
    y_k   = c_s − λ Σ_{j<k, j in s} (Δ_j,front − Δ_j,rear) + e_k
          (front/rear radius ratio in mm; c_s the set's unknown offset, marginalised under a
          Normal(segment mean, offset_sd_mm); e_k ~ N(0, σ_y² + sd_k²))
    W_j,a ~ N(Ŵ_j,a, sd_j,a² + τ² Ŵ_j,a²)                 the work's error and how well the drive
                                                          stands for its interval, marginalised:
                                                          y of a segment is multivariate normal
    depth_i ~ N(d0_p − Σ_j A_i,j,a Δ_j,a, σ_depth²)        readings (optional); d0_p ~ N(8, 0.5)

λ = 1 (the radius shrinks by the depth lost). The data fix only γ s (``gamma_work``, wear per joule
of *evidence* work): the model samples u = log γ s under its prior N(log gamma_median,
(gamma_log_sd² + WORK_SCALE_LOG_SD²)^½), and log s is drawn after the chains from its exact
conditional given u (it enters nothing else), which gives the posterior of γ itself.
:func:`fit_wear_history` returns the package's
:class:`~tyrebayes.inference.result.Fit` (kind ``"wear_history"``) with the predictions of
:func:`~tyrebayes.inference.wear.history_predict.wear_history_predictions` in its attributes.
"""

from __future__ import annotations

import json

import arviz_base as azb
import jax.numpy as jnp
import numpy as np
import numpyro
import numpyro.distributions as dist

from ...physics.wear import TreadGeometry
from ..nuts import run_nuts
from ..result import Fit, diagnose, provenance
from .data import WearPriors
from .history import DriveHistory, TreadReadings, reading_exposure

#: Log-sd of the scale error of a stream's friction work (eq. 4.19 from smoothed F_x and σ_x,
#: axle-level loads, the linear slip under braking): on 20 simulated years the evidence read the
#: simulator's true front-axle work at 0.81-0.88 of it (benchmarks/results/wear_history.json,
#: ``evidence_work_over_true``); the prior does not correct that, it makes γ's interval honest.
WORK_SCALE_LOG_SD = 0.2
#: Prior sd of a tyre set's radius-ratio offset [mm]: manufacturing spread of four tyres and
#: fitting, far wider than what a set's drives leave (effectively flat).
OFFSET_SD_MM = 3.0
#: Prior scale of the drive-to-drive ratio noise beyond the stated sd [mm] (pressure, load and
#: temperature move the rolling radius by tenths of a per mille between drives).
RATIO_NOISE_SCALE_MM = 0.1
#: Prior scale of τ, how much an interval's friction work differs from its logged drive's [-].
REPRESENTATIVENESS_SCALE = 0.3
#: Depth of a new tyre and its spread [mm] (a history starts on new tyres unless readings say
#: otherwise; replacements fit new tyres).
NEW_DEPTH_MM, NEW_DEPTH_SD_MM = 8.0, 0.5


def _segment_blocks(history: DriveHistory) -> list[np.ndarray]:
    return [np.nonzero(history.segment == s)[0] for s in np.unique(history.segment)]


def wear_history_model(
    history: DriveHistory,
    exposure: np.ndarray | None,
    read_pair: np.ndarray | None,
    depth_mm: np.ndarray | None,
    extended: bool,
    priors: WearPriors,
    wear_area_mm2: float,
):
    """The NumPyro model of the module docstring (static shapes; segments unrolled)."""
    prior_sd = float(np.hypot(priors.gamma_log_sd, WORK_SCALE_LOG_SD))
    log_gw = numpyro.sample(
        "log_gamma_work", dist.Normal(np.log(priors.gamma_median_mm3_per_j), prior_sd)
    )
    gamma = numpyro.deterministic("gamma_work", jnp.exp(log_gw))
    kappa = numpyro.sample("kappa", dist.Normal(0.0, priors.kappa_sd_per_k)) if extended else 0.0
    sigma_y = numpyro.sample("sigma_ratio_mm", dist.HalfNormal(RATIO_NOISE_SCALE_MM))
    tau = numpyro.sample("tau", dist.HalfNormal(REPRESENTATIVENESS_SCALE))
    factor = gamma * jnp.exp(kappa * (history.tyre_temperature_c - 20.0)) / 2.0 / wear_area_mm2
    work = jnp.asarray(history.work_j)
    loss = factor[:, None] * work  # (n, 2) mm per tyre
    diff = loss[:, 0] - loss[:, 1]
    var_w = jnp.asarray(history.work_sd_j) ** 2 + (tau * work) ** 2
    var_diff = factor**2 * (var_w[:, 0] + var_w[:, 1])
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
        d0 = numpyro.sample(
            "initial_depth_mm",
            dist.Normal(NEW_DEPTH_MM, NEW_DEPTH_SD_MM).expand([history.n_pairs]).to_event(1),
        )
        sigma_d = numpyro.sample("sigma_depth_mm", dist.HalfNormal(priors.depth_noise_scale_mm))
        lost = jnp.einsum("mja,ja->m", exposure, loss)
        numpyro.sample("depth", dist.Normal(d0[read_pair] - lost, sigma_d), obs=depth_mm)


def _split_work_scale(log_gw: np.ndarray, priors: WearPriors, seed: int) -> dict:
    """γ and s from draws of u = log γ s: log s | u is normal (both priors normal, module doc)."""
    mu, sg, ss = np.log(priors.gamma_median_mm3_per_j), priors.gamma_log_sd, WORK_SCALE_LOG_SD
    share = ss**2 / (sg**2 + ss**2)
    sd = ss * sg / np.hypot(sg, ss)
    rng = np.random.default_rng(seed + 7919)
    log_s = share * (log_gw - mu) + sd * rng.standard_normal(log_gw.shape)
    return {"gamma": np.exp(log_gw - log_s), "work_scale": np.exp(log_s)}


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
        ``kind="wear_history"``; diagnostics by :func:`~tyrebayes.inference.result.diagnose`
        over log γ s, σ_ratio, τ (and κ); ``gamma`` and ``work_scale`` are drawn after the
        chains (module docstring). ``data.attrs`` holds the history's tyre changes.
    """
    priors = WearPriors() if priors is None else priors
    geom = TreadGeometry() if geom is None else geom
    exposure = read_pair = depth = None
    if readings is not None and readings.depth_mm.size:
        exposure, read_pair = reading_exposure(history, readings)
        depth = np.asarray(readings.depth_mm)
    args = (history, exposure, read_pair, depth, extended, priors, float(geom.wear_area_mm2))
    init = {
        "log_gamma_work": np.log(priors.gamma_median_mm3_per_j),
        "sigma_ratio_mm": 0.02,
        "tau": 0.1,
    }
    if extended:
        init["kappa"] = 0.0
    if depth is not None:
        init["initial_depth_mm"] = np.full(history.n_pairs, NEW_DEPTH_MM)
        init["sigma_depth_mm"] = 0.2
    draws = run_nuts(
        wear_history_model,
        args,
        seed=seed,
        num_warmup=num_warmup,
        num_samples=num_samples,
        num_chains=num_chains,
        init_values=init,
        static_argnums=(0,),  # the drives' segments shape the model
        target_accept_prob=0.9,
    )
    samples = dict(draws.samples)
    samples.update(_split_work_scale(samples["log_gamma_work"], priors, seed))
    stats = {"diverging": draws.diverging}
    tree = azb.from_dict({"posterior": samples, "sample_stats": stats})
    changes = history.changes
    tree.attrs["tyre_changes"] = json.dumps(
        {
            "drive_index": changes.index.tolist(),
            "kind": list(changes.kind),
            "probability": changes.probability.tolist(),
            "statistic": changes.statistic.tolist(),
            "threshold": changes.threshold,
            "false_alarm_rate": changes.false_alarm_rate,
        }
    )
    tree.attrs["model"] = "extended" if extended else "baseline"
    names = ["log_gamma_work", "sigma_ratio_mm", "tau"] + (["kappa"] if extended else [])
    diagnostics = diagnose(tree, method="nuts", var_names=names)
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
