"""The V_max section's builder: predictive V_max per tyre set, the models tested on measured sets.

Each set runs on its own :class:`~tyrebayes.inference.vmax.VmaxInputs` or on the type relations
at its C_xr (:mod:`tyrebayes.inference.vmax`); with at least three measured sets (thesis Table
6.2) the driver-free and the extended model are compared on them.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from .._domain import load_vehicle
from ..inference import vmax as vm
from ..inference.summary import summarize
from .content import VmaxSection
from .sections import diagnostics_row


def vmax_section(
    vehicle_name: str,
    sets: list[dict],
    *,
    n_draws: int = 200,
    seed: int = 0,
    extended: bool = True,
) -> VmaxSection:
    """Predictive V_max per set; measured sets (``measured_lo`` given) also test the models.

    ``sets``: ``{"tyre", "tyre_type", "c_xr" (value or posterior draws), ["measured_lo"],
    ["inputs"]}``. A set with ``inputs`` (a :class:`~tyrebayes.inference.vmax.VmaxInputs`, e.g.
    :func:`~tyrebayes.inference.vmax.fit_vmax_inputs` of a fit with a lateral posterior) runs on
    those draws; the others on the type relations at their C_xr. Each row says its sources.
    Driver-free model: censored log predictive density of the measured intervals
    (:func:`tyrebayes.inference.vmax.censored_loglik`); extended (driver offset, adaptation,
    noise): PSIS-LOO of :func:`~tyrebayes.inference.vmax.fit_extended`.
    """
    vehicle = load_vehicle(vehicle_name)
    inputs = _set_inputs(sets, jax.random.PRNGKey(seed), n_draws)
    draws = _set_draws(vehicle, inputs)
    rows = [_vmax_row(s, d, x) for s, d, x in zip(sets, draws, inputs, strict=True)]
    measured = [r for r in rows if np.isfinite(r["measured_lo"])]
    comparison = _model_comparison(measured, seed, extended) if len(measured) >= 3 else {}
    return VmaxSection(vehicle=vehicle_name, rows=rows, comparison=comparison)


def _set_inputs(sets: list[dict], key, n_draws: int) -> list[vm.VmaxInputs]:
    """Each set's V_max inputs: its own ``inputs``, else the type relations at its C_xr."""
    inputs = []
    for i, s in enumerate(sets):
        if "inputs" in s:
            inputs.append(s["inputs"])
        else:
            k = jax.random.fold_in(key, i)
            inputs.append(vm.type_vmax_inputs(k, s["c_xr"], s["tyre_type"], n_draws))
    return inputs


def _set_draws(vehicle, inputs: list[vm.VmaxInputs]) -> list[np.ndarray]:
    """V_max draws [km/h] of each set, run as one vmapped batch (a single compilation)."""
    v = np.asarray(
        vm.vmax_draws(
            vehicle,
            jnp.asarray(np.concatenate([x.c_y_front for x in inputs])),
            jnp.asarray(np.concatenate([x.mu_y for x in inputs])),
            c_y_rear=jnp.asarray(np.concatenate([x.c_y_rear for x in inputs])),
        )
    )
    return np.split(v, np.cumsum([x.n_draws for x in inputs])[:-1])


def _vmax_row(s: dict, draws: np.ndarray, x: vm.VmaxInputs) -> dict:
    """One set's row: its draws and summary, the measured interval, the inputs' sources."""
    lo = float(s.get("measured_lo", np.nan))
    c = np.atleast_1d(np.asarray(s["c_xr"], float))
    beyond = vm.range_counts(draws)
    return {
        "tyre": s["tyre"],
        "tyre_type": s["tyre_type"],
        "c_xr": float(c.mean()),
        "draws": draws,
        "summary": summarize(draws).to_dict(),
        "not_bracketed": sum(beyond.values()),
        **beyond,
        "measured_lo": lo,
        "measured_hi": lo + vm.SPEED_STEP_KMH if np.isfinite(lo) else float("nan"),
        "lateral_source": x.lateral_source,
        "mu_y_source": x.mu_y_source,
        "surface": x.surface,
        "source_note": x.note,
    }


def _model_comparison(measured: list[dict], seed: int, extended: bool) -> dict:
    """Driver-free against extended model on the measured rows (:func:`vmax_section`).

    Driver-free: the censored log predictive density of the measured intervals, with the
    run-to-run repeatability; the measured and predicted slopes against C_xr; with
    ``extended``, the extended fit's PSIS-LOO and its gain over the driver-free model.
    """
    lo = np.array([r["measured_lo"] for r in measured])
    m = np.array([r["summary"]["mean"] for r in measured])
    sd = np.array([r["summary"]["sd"] for r in measured])
    ll0 = np.asarray(
        vm.censored_loglik(
            jnp.asarray(lo),
            vm.SPEED_STEP_KMH,
            jnp.asarray(m),
            jnp.sqrt(jnp.asarray(sd) ** 2 + vm.REPEATABILITY_KMH**2),
        )
    )
    comparison = {
        "driver_free": {"elpd": float(ll0.sum()), "se": float(np.sqrt(ll0.size * ll0.var()))},
        "measured_slope_kmh_per_cxr": float(np.polyfit([r["c_xr"] for r in measured], lo, 1)[0]),
        "predicted_slope_kmh_per_cxr": float(np.polyfit([r["c_xr"] for r in measured], m, 1)[0]),
    }
    if extended:
        comparison.update(_extended_comparison(lo, m, sd, ll0, seed))
    return comparison


def _extended_comparison(lo, m, sd, ll0: np.ndarray, seed: int) -> dict:
    """The extended model's PSIS-LOO, its parameters, and its elpd gain over ``ll0``."""
    ext = vm.fit_extended(lo, m, sd, seed=seed, num_samples=1000)
    loo = vm.psis_loo(vm.pointwise_log_lik(ext))
    diff = np.asarray(loo["pointwise"]) - ll0
    return {
        "extended": {
            "elpd_loo": float(loo["elpd_loo"]),
            "se": float(loo["se"]),
            "pareto_k_max": float(loo["pareto_k_max"]),
            "delta_kmh": summarize(ext.draws("delta_kmh")).to_dict(),
            "adaptation": summarize(ext.draws("adaptation")).to_dict(),
            "sigma_driver_kmh": summarize(ext.draws("sigma_driver_kmh")).to_dict(),
            "divergences": ext.diagnostics.divergences,
            "diagnostics": diagnostics_row(ext.diagnostics, "V_max extended"),
        },
        "elpd_gain": {"diff": float(diff.sum()), "se": float(np.sqrt(diff.size * diff.var()))},
    }
