"""The demo's wear study: a soft and a stiff tyre driven through a year, baseline vs extended.

A small version of ``benchmarks/wear_thesis.py``: winter (soft) and summer (stiff) sets are driven
through a year of seasonal weather by :func:`tyrebayes.simulate.wear.simulate_drives` with a
temperature-dependent abrasability (the simulated world has the effect the thesis' model lacks:
soft compounds wear faster in heat); tread-depth readings and radius drift are observed; the
baseline (κ = 0, the thesis' model) and the extended model (κ per type) are fitted by a
MAP + Laplace approximation (:func:`fit_wear_svi`; NUTS via
:func:`tyrebayes.inference.wear.fit_wear` takes minutes here) and compared by PSIS-LOO. The
section shows each model's predicted wear rate at an ambient temperature relative to the same
tyre at ``REFERENCE_C`` (thesis Sec. 6.2 compares 7 and 40 °C), per posterior draw.
"""

from __future__ import annotations

import warnings
from functools import partial

import numpy as np

from .content import WearSection

#: True temperature sensitivities of abrasability in the simulated world [1/K] (assumption:
#: soft winter compounds lose wear resistance in heat faster, as in benchmarks/wear_thesis.py).
KAPPA_TRUE = {"winter": 0.03, "summer": 0.008}
#: Soft and stiff tyre of the thesis' Table 6.1 study (C_xr 29 and 60).
TYRES = {"soft": ("winter", 29.0), "stiff": ("summer", 60.0)}
#: True abrasability at 20 °C [mm³/J], a mid-range Schallamach value (see inference.wear priors).
GAMMA_TRUE = 0.04
REFERENCE_C = 7.0
AMBIENTS_C = (-5.0, 7.0, 15.0, 25.0, 32.0, 40.0)


#: Settings of the wear fits: MAP by Adam on the unconstrained parameters, then a Laplace
#: (Gaussian at the mode, Hessian covariance) approximation of the posterior.
SVI_STEPS = 4000
SVI_DRAWS = 1000
SVI_LEARNING_RATE = 0.02


#: Deterministic sites of :func:`tyrebayes.inference.wear.wear_model`.
_DETERMINISTIC_SITES = ("tau", "c_xr", "gamma")


def fit_wear_svi(data, extended: bool, seed: int = 0, steps: int = SVI_STEPS):
    """MAP + Laplace fit of :func:`tyrebayes.inference.wear.wear_model`.

    NUTS on the wear model needs minutes on a small machine (dense mass, deep trees along the
    γ / C_xr ridge); a Gaussian at the mode with the inverse Hessian as covariance captures that
    correlation at the cost of a few thousand gradient steps. Returns a
    :class:`~tyrebayes.inference.wear.WearFit` whose diagnostics say ``method="laplace"`` and
    whether the optimisation settled (the deterministic loss changed by less than 1e-4
    relative between the last two tenths of the run) with a finite covariance.
    """
    import arviz as az
    import jax
    from numpyro.infer import SVI, Predictive, Trace_ELBO, init_to_value, log_likelihood
    from numpyro.infer.autoguide import AutoLaplaceApproximation
    from numpyro.optim import Adam

    from ..inference.wear import WearFit, WearPriors, _init_values, wear_model
    from ..physics.thermal import StiffnessTemperature

    priors, comp = WearPriors(), StiffnessTemperature()
    guide = AutoLaplaceApproximation(
        wear_model, init_loc_fn=init_to_value(values=_init_values(data, extended, priors))
    )

    # Exponentially decaying step (to 1 % of the start): the MAP search settles instead of
    # circling the mode at a constant step size.
    def step_size(i):
        return SVI_LEARNING_RATE * 0.01 ** (i / steps)

    svi = SVI(wear_model, guide, Adam(step_size), Trace_ELBO())
    key_fit, key_draw, key_det = jax.random.split(jax.random.PRNGKey(seed), 3)
    result = svi.run(key_fit, steps, data, extended, priors, comp, progress_bar=False)
    losses = np.asarray(result.losses)
    tenth = max(len(losses) // 10, 1)
    last, before = losses[-tenth:].mean(), losses[-2 * tenth : -tenth].mean()
    settled = bool(np.isfinite(last) and abs(last - before) <= 1e-4 * max(abs(last), 1.0))

    # Jitted as a whole: run eagerly, the Hessian and the vmapped log densities dispatch (and
    # compile) hundreds of single operations.
    @jax.jit
    def draws_and_loglik(params, key_draw, key_det):
        latent = guide.sample_posterior(key_draw, params, sample_shape=(SVI_DRAWS,))
        det = Predictive(
            wear_model, posterior_samples=latent, return_sites=["c_xr", "gamma", "tau"]
        )(key_det, data, extended, priors, comp)
        return latent, det, log_likelihood(wear_model, latent, data, extended, priors, comp)

    # numpyro's MultivariateNormal.sample broadcasts loc (k,) against (draws, k): allowed here
    # even where the package runs with strict rank promotion.
    with jax.numpy_rank_promotion("allow"):
        latent, det, loglik = draws_and_loglik(result.params, key_draw, key_det)
    finite = all(bool(np.all(np.isfinite(np.asarray(v)))) for v in latent.values())
    # a collapsed covariance (MAP at a boundary) gives draws without spread: not a posterior
    # (the guide also returns the model's deterministic sites; τ is a constant 0 without pooling)
    degenerate = any(
        bool(np.any(np.std(np.asarray(v), axis=0) < 1e-12))
        for k, v in latent.items()
        if k not in _DETERMINISTIC_SITES
    )
    samples = {k: np.asarray(v) for k, v in {**latent, **det}.items()}
    observed = {"depth": data.depth_mm} if data.depth_mm.size else {}
    idata = az.from_dict(
        posterior={k: v[None] for k, v in samples.items()},
        log_likelihood={k: np.asarray(v)[None] for k, v in loglik.items()},
        observed_data=observed,
    )
    diagnostics = {
        "method": "laplace",
        "r_hat_max": float("nan"),
        "ess_min": float(SVI_DRAWS),
        "divergences": 0,
        "converged": settled and finite and not degenerate,
        "reason": "; ".join(
            r
            for r, bad in (
                ("loss still changing at the end of the run", not settled),
                ("non-finite draws", not finite),
                ("degenerate covariance (mode at a boundary)", degenerate),
            )
            if bad
        ),
        "final_loss": float(last),
    }
    return WearFit(idata, samples, data, extended, comp, diagnostics)


def _simulator(profile, n_drives: int):
    """``simulate_drives`` compiled once for all stiffnesses, temperatures and abrasabilities.

    Called directly, every call re-traces (the per-drive function closes over its arguments);
    with temperatures and abrasability as traced arguments one compilation per stiffness serves
    the whole study.
    """
    import jax

    from ..physics.wear import Abrasability
    from ..simulate.wear import simulate_drives

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
    import arviz as az
    import jax
    import jax.numpy as jnp

    from .._commands.wear import thesis_reproduction
    from ..inference.summary import summarize
    from ..inference.wear import build_wear_data, predict_wear_volume
    from ..simulate.wear import DutyProfile, observe_wear, seasonal_ambient

    tick = progress or (lambda _name: None)
    key = jax.random.PRNGKey(seed)
    n_drives = 60 if quick else 150
    # One set per type: with two, the type spread τ enters and its MAP runs off to τ = 0 (the
    # funnel of a centred hierarchy), where a Laplace approximation collapses.
    per_type = 1
    profile = DutyProfile(drive_duration_s=1800.0, dt_s=6.0 if quick else 4.0)
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
            sets.append((work, obs, tyre_type, (c_set, 0.05 * c_set)))
            truth_sets.append((name, tyre_type, c_set, gamma))
        tick(f"simulated {name} sets")
    data = build_wear_data(sets, type_names=("winter", "summer"))
    fits = {}
    for model, ext in (("baseline", False), ("extended", True)):
        # more sets and drives: a longer, flatter ridge to climb
        steps = SVI_STEPS if quick else 3 * SVI_STEPS
        fits[model] = fit_wear_svi(data, extended=ext, seed=seed + 3, steps=steps)
        tick(f"fitted {model} wear model")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loo = {m: az.loo(f.idata, var_name="depth", pointwise=True) for m, f in fits.items()}
    diff = np.asarray(loo["extended"].loo_i) - np.asarray(loo["baseline"].loo_i)
    comparison = {
        m: {
            "elpd_loo": float(v.elpd_loo),
            "se": float(v.se),
            "pareto_k_max": float(np.max(v.pareto_k)),
        }
        for m, v in loo.items()
    }
    comparison["elpd_gain_extended"] = {
        "diff": float(diff.sum()),
        "se": float(np.sqrt(diff.size) * diff.std(ddof=1)),
    }

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
        from ..physics.thermal import stiffness_at_temperature

        def true_volume(amb, _t=tyre_type, _c=c_xr, _g=gamma_true, kernels=kernels):
            k, grid = kernels[amb]
            c_x = np.asarray(stiffness_at_temperature(_c, jnp.asarray(grid), fits["baseline"].comp))
            return float((_g * k @ (np.exp(KAPPA_TRUE[_t] * (grid - 20.0)) / c_x)).sum())

        for m, f in fits.items():
            k_ref, grid = kernels[REFERENCE_C]
            ref = predict_wear_volume(f, k_ref, grid, set_index=set_index).sum(axis=1)
            q = []
            for amb in AMBIENTS_C:
                k, grid = kernels[amb]
                vol = predict_wear_volume(f, k, grid, set_index=set_index).sum(axis=1)
                q.append(np.quantile(vol / ref, (0.05, 0.5, 0.95)))
            q = np.array(q)
            curves[m][name] = {
                "ambient_c": np.array(AMBIENTS_C),
                "q05": q[:, 0],
                "q50": q[:, 1],
                "q95": q[:, 2],
                "c_xr": c_xr,
                "tyre_type": tyre_type,
                "truth": np.array([true_volume(a) for a in AMBIENTS_C]) / true_volume(REFERENCE_C),
            }
        tick(f"predicted {name} wear curves")
    ext = fits["extended"]
    kappa = {
        t: {**summarize(ext.samples["kappa"][:, i]), "true": KAPPA_TRUE[t]}
        for i, t in enumerate(data.type_names)
    }
    thesis = thesis_reproduction(TYRES["soft"][1], TYRES["stiff"][1])
    return WearSection(
        reference_c=REFERENCE_C,
        curves=curves,
        kappa=kappa,
        comparison=comparison,
        diagnostics={m: f.diagnostics for m, f in fits.items()},
        thesis={
            "relative_wear_difference": thesis["relative_wear_difference"],
            "soft_wears_relatively_more_in_heat": thesis["soft_wears_relatively_more_in_heat"],
            "rolling_loss_w": thesis["rolling_loss_w"],
        },
    )
