"""The measured V_max of thesis Table 6.2 as interval-censored data, and the models for it.

The driver raised the speed in steps of 10 km/h until a cone fell, so the recorded V_max means
V ∈ [v_pass, v_pass + 10) km/h (interval censoring). Models for the six measured sets:

* **driver-free**: V_i ~ Normal(m_i, s_i² + σ_rep²), (m_i, s_i) the simulation's predictive mean
  and sd, σ_rep = 2 km/h run-to-run repeatability, no free parameters;
* **extended**: V_i ~ Normal(m_i + δ − a (m_i − m̄), s_i² + σ_d²) with a driver offset
  δ ~ Normal(0, 20) km/h (a skilled driver beats the simple preview driver), an adaptation
  a ~ Normal(0, 1) (the fraction of the predicted tyre effect the driver compensates) and driver
  noise σ_d ~ HalfNormal(10) km/h, in NumPyro.
"""

from __future__ import annotations

import arviz_base as azb
import jax.numpy as jnp
import numpy as np
import numpyro
import numpyro.distributions as dist
import pandas as pd
from jax.scipy.special import ndtr
from jaxtyping import Array, Float

from ..._domain import load_lane_change_speeds
from ..nuts import run_nuts
from ..result import Fit, diagnose, loo, provenance

SPEED_STEP_KMH = 10.0
REPEATABILITY_KMH = 2.0


def load_table_6_2() -> pd.DataFrame:
    """The six ISO 3888-2 rows of the measured file (tyre, tyre_type, c_xr, v_max_kmh)."""
    return load_lane_change_speeds("thesis Table 6.2")


def censored_loglik(
    lo_kmh: Float[Array, "n"], step_kmh: float, mean: Float[Array, "n"], sd: Float[Array, "n"]
) -> Float[Array, "n"]:
    """log P(lo ≤ V < lo + step) for V ~ Normal(mean, sd) (interval-censored observation)."""
    a = ndtr((lo_kmh - mean) / sd)
    b = ndtr((lo_kmh + step_kmh - mean) / sd)
    return jnp.log(jnp.clip(b - a, 1e-300, 1.0))


def extended_model(
    lo_kmh: Float[Array, "n"], m: Float[Array, "n"], s: Float[Array, "n"], step_kmh: float
) -> None:
    """NumPyro model: driver offset δ and driver noise σ_d on top of the simulation."""
    delta = numpyro.sample("delta_kmh", dist.Normal(0.0, 20.0))
    sigma = numpyro.sample("sigma_driver_kmh", dist.HalfNormal(10.0))
    # adaptation: the fraction of the predicted tyre effect the driver cancels (0 none, 1 all)
    adapt = numpyro.sample("adaptation", dist.Normal(0.0, 1.0))
    mean = m + delta - adapt * (m - jnp.mean(m))
    sd = jnp.sqrt(s**2 + sigma**2)
    ll = censored_loglik(lo_kmh, step_kmh, mean, sd)
    numpyro.deterministic("log_lik", ll)
    numpyro.factor("obs", jnp.sum(ll))


def fit_extended(
    lo_kmh: np.ndarray, m: np.ndarray, s: np.ndarray, seed: int = 0, num_samples: int = 1000
) -> Fit:
    """NUTS fit of :func:`extended_model` (one chain, 500 warm-up steps).

    Returns a :class:`~tyrebayes.inference.result.Fit` of kind ``"vmax"``: posterior
    ``delta_kmh``, ``sigma_driver_kmh``, ``adaptation``; ``log_likelihood["v_max"]`` per measured
    set (interval-censored); diagnostics under the package's policy (one chain: no R-hat).
    """
    run = run_nuts(
        extended_model,
        (jnp.asarray(lo_kmh), jnp.asarray(m), jnp.asarray(s), SPEED_STEP_KMH),
        seed=seed,
        num_warmup=500,
        num_samples=num_samples,
    )
    draws = dict(run.samples)
    log_lik = draws.pop("log_lik")
    data = azb.from_dict(
        {
            "posterior": draws,
            "log_likelihood": {"v_max": log_lik},
            "observed_data": {"v_max": np.asarray(lo_kmh, float)},
            "constant_data": {"predicted_mean": np.asarray(m), "predicted_sd": np.asarray(s)},
            "sample_stats": {"diverging": run.diverging},
        },
        dims={
            "v_max": ["measured_set"],
            "predicted_mean": ["measured_set"],
            "predicted_sd": ["measured_set"],
        },
    )
    return Fit(
        data=data,
        diagnostics=diagnose(data, method="nuts"),
        kind="vmax",
        provenance=provenance("nuts", "extended", ("lane-change intervals in memory",), seed=seed),
    )


def pointwise_log_lik(fit: Fit) -> np.ndarray:
    """The extended fit's log-likelihood per draw and measured set, (draws × n)."""
    values = np.asarray(fit.data["log_likelihood"]["v_max"])
    return values.reshape(-1, values.shape[-1])


def psis_loo(log_lik: np.ndarray) -> dict[str, float]:
    """PSIS-LOO elpd and its SE from a (draws × n) pointwise log-likelihood (arviz-stats)."""
    data = azb.from_dict(
        {
            "posterior": {"x": np.zeros((1, log_lik.shape[0]))},
            "log_likelihood": {"y": log_lik[None, :, :]},
        }
    )
    res = loo(data)
    return {
        "elpd_loo": float(res.elpd),
        "se": float(res.se),
        "pointwise": np.asarray(res.elpd_i).tolist(),
        "pareto_k_max": float(np.max(np.asarray(res.pareto_k))),
    }


def power_table(
    delta_kmh: float,
    sigma_kmh: float,
    steps_kmh: tuple[float, ...] = (10.0, 5.0, 2.0, 1.0),
    sessions: tuple[int, ...] = (1, 2, 3, 5, 10, 20),
    n_mc: int = 20000,
    seed: int = 0,
) -> list[dict[str, float]]:
    """P(the stiff set's mean recorded V_max exceeds the soft set's) per speed step and sessions.

    Each session is one staircase per set: true V = mean + Normal(0, σ) (driver/run noise), the
    recorded value is the last passed step floor(V/step)·step; the test "resolves" the difference
    when the mean over sessions of the stiff set is strictly larger.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for step in steps_kmh:
        for n in sessions:
            soft = rng.normal(70.0, sigma_kmh, (n_mc, n))
            stiff = rng.normal(70.0 + delta_kmh, sigma_kmh, (n_mc, n))
            phase = rng.uniform(0.0, step, (n_mc, 1))  # the step grid's phase, shared by both
            rec_soft = np.floor((soft - phase) / step).mean(axis=1)
            rec_stiff = np.floor((stiff - phase) / step).mean(axis=1)
            p_resolve = float(np.mean(rec_stiff > rec_soft))
            rows.append({"step_kmh": step, "sessions": n, "p_resolve": p_resolve})
    return rows
