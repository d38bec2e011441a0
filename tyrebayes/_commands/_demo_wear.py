"""The demo's wear study: a soft and a stiff tyre driven through a year, baseline vs extended.

A small version of ``benchmarks/wear_thesis.py``: winter (soft) and summer (stiff) sets are driven
through a year of seasonal weather by :func:`tyrebayes.simulate.wear.simulate_drives` with a
temperature-dependent abrasability (the simulated world has the effect the thesis' model lacks:
soft compounds wear faster in heat); tread-depth readings and radius drift are observed; the
baseline (κ = 0, the thesis' model) and the extended model (κ per type) are fitted by a
MAP + Laplace approximation (:func:`tyrebayes.inference.wear.fit_wear` with
``method="laplace"``; NUTS takes minutes here) and compared by PSIS-LOO. A helper of the demo
command: it makes its data with :mod:`tyrebayes.simulate`. The
section shows each model's predicted wear rate at an ambient temperature relative to the same
tyre at ``REFERENCE_C`` (thesis Sec. 6.2 compares 7 and 40 °C), per posterior draw.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from ..inference.result import loo as psis_loo
from ..inference.summary import summarize
from ..inference.wear import WearSet, build_wear_data, fit_wear, predict_wear_volume
from ..physics.thermal import StiffnessTemperature, stiffness_at_temperature
from ..physics.wear import Abrasability, thesis_reproduction
from ..report.content import WearSection
from ..report.sections import diagnostics_row
from ..simulate.wear import DutyProfile, observe_wear, seasonal_ambient, simulate_drives

#: True temperature sensitivities of abrasability in the simulated world [1/K] (assumption:
#: soft winter compounds lose wear resistance in heat faster, as in benchmarks/wear_thesis.py).
KAPPA_TRUE = {"winter": 0.03, "summer": 0.008}
#: Soft and stiff tyre of the thesis' Table 6.1 study (C_xr 29 and 60).
TYRES = {"soft": ("winter", 29.0), "stiff": ("summer", 60.0)}
#: True abrasability at 20 °C [mm³/J], a mid-range Schallamach value (see inference.wear priors).
GAMMA_TRUE = 0.04
REFERENCE_C = 7.0
AMBIENTS_C = (-5.0, 7.0, 15.0, 25.0, 32.0, 40.0)


#: Adam steps of the wear fits' MAP search (MAP + Laplace, :func:`fit_wear` method "laplace").
LAPLACE_STEPS = 4000


def _simulator(profile, n_drives: int):
    """``simulate_drives`` compiled once for all stiffnesses, temperatures and abrasabilities.

    Called directly, every call re-traces (the per-drive function closes over its arguments);
    with temperatures and abrasability as traced arguments one compilation per stiffness serves
    the whole study.
    """

    # c_xr is static: simulate_drives declares it a Python float (checked at test time).
    @partial(jax.jit, static_argnames="c_xr")
    def sim(key, ambient_c, c_xr, gamma, kappa, speed_mps):
        return simulate_drives(
            key,
            n_drives,
            ambient_c,
            c_xr,
            Abrasability(gamma, kappa),
            profile,
            mean_speed_mps=speed_mps,
        )

    return sim


def wear_study(seed: int = 0, *, quick: bool = False, progress=None) -> WearSection:
    """Simulate, fit baseline and extended wear models, and build the wear section.

    ``quick`` uses 2 sets (one per type) of 60 drives and 6 readings; otherwise 150 drives and
    8 readings.
    ``progress`` is a callable ``progress(step_name)`` or None.
    """
    tick = progress or (lambda _name: None)
    profile = DutyProfile(drive_duration_s=1800.0, dt_s=6.0 if quick else 4.0)
    sets, truth_sets = _simulate_sets(seed, quick, profile, tick)
    data = build_wear_data(sets, type_names=("winter", "summer"))
    fits = _fit_models(data, seed, quick, tick)
    curves = _wear_curves(fits, truth_sets, profile, seed, quick, tick)
    ext = fits["extended"]
    kappa = {
        t: {**summarize(ext.draws("kappa")[:, i]).to_dict(), "true": KAPPA_TRUE[t]}
        for i, t in enumerate(data.type_names)
    }
    thesis = thesis_reproduction(TYRES["soft"][1], TYRES["stiff"][1])
    return WearSection(
        reference_c=REFERENCE_C,
        curves=curves,
        kappa=kappa,
        comparison=_loo_comparison(fits),
        diagnostics={m: diagnostics_row(f.diagnostics) for m, f in fits.items()},
        thesis={
            "relative_wear_difference": thesis["relative_wear_difference"],
            "soft_wears_relatively_more_in_heat": thesis["soft_wears_relatively_more_in_heat"],
            "rolling_loss_w": thesis["rolling_loss_w"],
        },
    )


def _simulate_sets(seed: int, quick: bool, profile: DutyProfile, tick):
    """Drive each tyre of :data:`TYRES` through a year of seasonal weather and observe its
    tread depth; returns the wear sets and, per set, (name, type, C_xr, true gamma)."""
    key = jax.random.PRNGKey(seed)
    n_drives = 60 if quick else 150
    # One set per type: with two, the type spread τ enters and its MAP runs off to τ = 0 (the
    # funnel of a centred hierarchy), where a Laplace approximation collapses.
    per_type = 1
    simulate = _simulator(profile, n_drives)
    sets, truth_sets = [], []
    for ti, (name, (tyre_type, c_xr)) in enumerate(TYRES.items()):
        for j in range(per_type):
            k = jax.random.fold_in(key, 10 * ti + j)
            k1, k2, k3, k4 = jax.random.split(k, 4)
            day = jnp.linspace(0.0, 365.0, n_drives)
            amb = seasonal_ambient(k1, day)
            speed = jax.random.uniform(k2, (n_drives,), minval=30 / 3.6, maxval=110 / 3.6)
            gamma = GAMMA_TRUE * float(jnp.exp(0.1 * jax.random.normal(k3)))
            c_set = float(c_xr * (1.0 + 0.03 * j))
            work = simulate(
                k4, amb, c_xr=c_set, gamma=gamma, kappa=KAPPA_TRUE[tyre_type], speed_mps=speed
            )
            km = float(np.sum(np.asarray(work.distance_km)))
            readings = np.linspace(0.0, km, 6 if quick else 8)
            obs = observe_wear(jax.random.fold_in(k, 99), work, readings, 0.1, 3e-4)
            sets.append(WearSet.from_c_xr(work, obs, tyre_type, (c_set, 0.05 * c_set)))
            truth_sets.append((name, tyre_type, c_set, gamma))
        tick(f"simulated {name} sets")
    return sets, truth_sets


def _fit_models(data, seed: int, quick: bool, tick) -> dict:
    """The baseline (κ = 0) and extended (κ per type) wear fits, MAP + Laplace."""
    fits = {}
    for model, ext in (("baseline", False), ("extended", True)):
        # more sets and drives: a longer, flatter ridge to climb
        steps = LAPLACE_STEPS if quick else 3 * LAPLACE_STEPS
        fits[model] = fit_wear(
            data, extended=ext, method="laplace", laplace_steps=steps, seed=seed + 3
        )
        tick(f"fitted {model} wear model")
    return fits


def _loo_comparison(fits: dict) -> dict:
    """PSIS-LOO of each model's depth readings and the extended model's ELPD gain (with its
    SE)."""
    loo = {m: psis_loo(f.data, var_name="depth") for m, f in fits.items()}
    diff = np.asarray(loo["extended"].elpd_i) - np.asarray(loo["baseline"].elpd_i)
    comparison = {
        m: {
            "elpd_loo": float(v.elpd),
            "se": float(v.se),
            "pareto_k_max": float(np.max(v.pareto_k)),
        }
        for m, v in loo.items()
    }
    comparison["elpd_gain_extended"] = {
        "diff": float(diff.sum()),
        "se": float(np.sqrt(diff.size) * diff.std(ddof=1)),
    }
    return comparison


def _wear_curves(
    fits: dict, truth_sets: list, profile: DutyProfile, seed: int, quick: bool, tick
) -> dict:
    """Per model and tyre: the predicted wear rate at each of :data:`AMBIENTS_C` relative to
    the same tyre at :data:`REFERENCE_C` (5, 50, 95 % quantiles over the draws) beside the
    simulated world's true ratio."""
    comp = StiffnessTemperature()  # the fits' default compensation
    curves = {m: {} for m in fits}
    kern_key = jax.random.PRNGKey(seed + 8)
    n_kernel_drives = 6 if quick else 12
    simulate_kernel = _simulator(profile, n_kernel_drives)

    def profile_kernel(amb: float, c_xr: float):
        """Binned friction-work kernel of 1000 km at an ambient (simulate.wear.profile_kernel)."""
        n = n_kernel_drives
        work = simulate_kernel(
            kern_key,
            jnp.full((n,), amb),
            c_xr=float(c_xr),
            gamma=1.0,
            kappa=0.0,
            speed_mps=jnp.full((n,), profile.mean_speed_mps),
        )
        scale = 1000.0 / float(jnp.sum(work.distance_km))
        return np.asarray(work.kernel_binned.sum(axis=0)) * scale, np.asarray(work.grid_c)

    for name, (tyre_type, c_xr) in TYRES.items():
        set_index = next(i for i, s in enumerate(truth_sets) if s[0] == name)
        gamma_true = truth_sets[set_index][3]
        kernels = {
            amb: profile_kernel(amb, c_xr) for amb in sorted(set(AMBIENTS_C) | {REFERENCE_C})
        }

        def true_volume(amb, _t=tyre_type, _c=c_xr, _g=gamma_true, kernels=kernels):
            k, grid = kernels[amb]
            c_x = np.asarray(stiffness_at_temperature(_c, jnp.asarray(grid), comp))
            return float((_g * k @ (np.exp(KAPPA_TRUE[_t] * (grid - 20.0)) / c_x)).sum())

        truth = np.array([true_volume(a) for a in AMBIENTS_C]) / true_volume(REFERENCE_C)
        for m, f in fits.items():
            curves[m][name] = {
                **_relative_wear_quantiles(f, kernels, set_index),
                "c_xr": c_xr,
                "tyre_type": tyre_type,
                "truth": truth,
            }
        tick(f"predicted {name} wear curves")
    return curves


def _relative_wear_quantiles(fit, kernels: dict, set_index: int) -> dict:
    """``ambient_c`` and the 5, 50, 95 % quantiles (``q05``, ``q50``, ``q95``) of one fit's
    predicted wear volume at each ambient over that at :data:`REFERENCE_C`."""
    k_ref, grid = kernels[REFERENCE_C]
    ref = predict_wear_volume(fit, k_ref, grid, set_index=set_index).sum(axis=1)
    q = []
    for amb in AMBIENTS_C:
        k, grid = kernels[amb]
        vol = predict_wear_volume(fit, k, grid, set_index=set_index).sum(axis=1)
        q.append(np.quantile(vol / ref, (0.05, 0.5, 0.95)))
    q = np.array(q)
    return {"ambient_c": np.array(AMBIENTS_C), "q05": q[:, 0], "q50": q[:, 1], "q95": q[:, 2]}
