"""What a lateral posterior says about its drive: identification, μ_y observed, adequacy.

Also the partial slips the report plots: each axle's force against its slip angle as the data
see it, at the posterior mean.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import xarray as xr

from .data import CorneringObservations, G
from .mode import _residuals_at
from .model import LateralPriors, axle_state

#: μ_y counts as observed where an axle used this share of it (and the data narrowed it).
MU_Y_USE_OBSERVED = 0.8
#: ... and where its posterior log-sd is at most this share of the prior's.
MU_Y_CONTRACTION = 0.5
#: The understeer gradient counts as identified where its posterior sd is at most this share
#: of the prior's.
K_CONTRACTION = 0.5
#: The yaw inertia is known from the vehicle file (its prior: ±15 %, one log-sd). A posterior
#: whose mean lies more than this many prior sds away is a conflict between prior and data.
PRIOR_CONFLICT_SDS = 3.0


@jax.jit
def _state_at(point: dict, obs):
    return axle_state(obs, point)


def _identification(
    priors: LateralPriors, surface: str, samples: dict, state, obs, seed: int
) -> tuple[bool, bool, float]:
    """(K identified, μ_y observed, peak use) of the posterior ``samples`` against the prior."""
    rng = np.random.default_rng(seed)
    c = np.exp(rng.normal(np.log(priors.c_y_median), priors.c_y_log_sd, (2, 4000)))
    k_prior_sd = float(np.std((1.0 / c[0] - 1.0 / c[1]) / G))
    identified = float(np.std(samples["understeer_gradient"])) <= K_CONTRACTION * k_prior_sd
    mask = np.asarray(obs.mask)
    rho = np.abs(np.r_[np.asarray(state.rho_front)[mask], np.asarray(state.rho_rear)[mask]])
    use = float(np.quantile(rho, 0.99) / np.mean(samples["mu_y"])) if rho.size else 0.0
    _, mu_log_sd = priors.mu_y_prior(surface)
    narrowed = float(np.std(np.log(samples["mu_y"]))) <= MU_Y_CONTRACTION * mu_log_sd
    return identified, bool(narrowed and use >= MU_Y_USE_OBSERVED), use


#: Samples of a drive kept in its fit for the report's slip-angle plot (thinned evenly).
PLOT_SAMPLES = 1500


def _partial_slips(obs: CorneringObservations, state, samples: dict) -> xr.Dataset:
    """Each axle's force against its slip angle as the data see it, at the posterior mean.

    No car measures a slip angle; the steering equation measures the difference
    α_f − α_r = δ − L r/V_x. Each axle's "data" slip angle is that measured difference with the
    other axle's model slip added back: points that scatter about the axle's fitted curve by the
    steering equation's misfit (a partial-residual plot).
    """
    point = {k: float(np.mean(v)) for k, v in samples.items() if np.ndim(v) == 2}
    ratio = 1.0 if obs.road_wheel else point["steering_ratio"]
    offset = point.get("steering_offset", 0.0)
    mask = np.asarray(obs.mask)
    measured = (np.asarray(obs.steering) - offset) / ratio - np.asarray(
        obs.wheelbase_m * obs.yaw_rate / obs.speed
    )
    keep = np.flatnonzero(mask)
    keep = keep[np.linspace(0, keep.size - 1, min(PLOT_SAMPLES, keep.size)).astype(int)]
    alpha_f, alpha_r = np.asarray(state.alpha_front), np.asarray(state.alpha_rear)
    return xr.Dataset(
        {
            "rho_front": ("sample", np.asarray(state.rho_front)[keep]),
            "rho_rear": ("sample", np.asarray(state.rho_rear)[keep]),
            "alpha_front_partial": ("sample", (measured + alpha_r)[keep]),
            "alpha_rear_partial": ("sample", (alpha_f - measured)[keep]),
        }
    )


def _mean_point(samples: dict) -> dict:
    return {k: jnp.asarray(np.mean(v, axis=0)) for k, v in samples.items()}


def _adequacy(
    obs: CorneringObservations, samples: dict, vif: tuple[float, float], priors: LateralPriors
) -> list[str]:
    """Reasons the model does not describe the drive (:func:`_bends`, :func:`_yaw_inertia`)."""
    return _bends(obs, samples, vif) + _yaw_inertia(samples, priors)


def _yaw_inertia(samples: dict, priors: LateralPriors) -> list[str]:
    """A yaw inertia pulled far from the vehicle file's: the yaw transients do not fit.

    With the understeer gradient fixed by steady cornering, the axles' common stiffness level
    rests on the transients (J_z ṙ in the axle forces, the sideslip rate in the kinematic
    equation: the model docstring's equations), so a J_z that the data pull far from the vehicle
    file's says those transients do not fit, and the level is not to be used. It is a partial
    guard: where the transients are weak, a_y's noise through the sideslip rate reads the tyres
    stiff whether or not J_z moves (``benchmarks/results/lateral_simulated_drives.json`` counts
    the fits it flags; the lateral guide says why).
    """
    draws = samples.get("yaw_inertia_factor")
    if draws is None or priors.yaw_inertia_log_sd <= 0:
        return []
    factor = float(np.exp(np.mean(np.log(draws))))
    sds = math.log(factor) / priors.yaw_inertia_log_sd
    if abs(sds) <= PRIOR_CONFLICT_SDS:
        return []
    return [
        f"yaw inertia pulled to {factor:.2f}x the vehicle file's ({sds:+.1f} prior sds): the "
        "yaw transients, on which the stiffnesses' level rests, do not fit"
    ]


def _bends(obs: CorneringObservations, samples: dict, vif: tuple[float, float]) -> list[str]:
    """A trend of the steering residual with a_y.

    The residual's mean in eight a_y bins, each against its standard error (inflated by the
    residuals' correlation), should stay within ±4: a tyre curve or a steering model that
    does not fit shows as a systematic bend against a_y.
    """
    steer = np.asarray(_residuals_at(_mean_point(samples), obs)[0])
    mask = np.asarray(obs.mask)
    ay = np.asarray(obs.ay)[mask]
    r = steer[mask]
    if r.size < 80:
        return []
    edges = np.quantile(ay, np.linspace(0, 1, 9))
    idx = np.clip(np.searchsorted(edges, ay, side="right") - 1, 0, 7)
    sd = float(np.std(r))
    worst = 0.0
    for b in range(8):
        rb = r[idx == b]
        if rb.size >= 10:
            worst = max(worst, abs(float(np.mean(rb))) / (sd * np.sqrt(vif[0] / rb.size)))
    if worst > 4.0:
        return [f"steering residual bends with a_y ({worst:.1f} standard errors in one bin)"]
    return []
