"""Abrasability gamma from tread-depth readings and/or rolling-radius drift (NumPyro).

Model (per tyre set *s* of type *t*, drive *d*, axle *a*, temperature bin *b*)::

    mu_t            ~ Normal(log gamma_median, gamma_log_sd)          type-level log abrasability
    tau             ~ HalfNormal(type_spread)                          spread of sets within a type
    log gamma_s     ~ Normal(mu_t, tau)                                (pooled by type)
    C_xr,s          ~ LogNormal(from the per-tyre posterior: draws or mean/sd)   marginalised
    kappa_t         ~ Normal(0, kappa_sd)      [extended model only; baseline kappa = 0]
    V_s,d,a         = gamma_s sum_b K_s,d,a,b exp(kappa_t (T_b - 20)) / C_x(C_xr,s, T_b)
                      (thesis eq. 4.26 with slip 4.27; K = binned rho^2 F_z V dt from the drive)
    loss_s,d,a      = cumsum_d V / A_wear                              depth lost [mm]
    depth_j         ~ Normal(d0_s,a - loss_s,d(j),a(j), sigma_depth)   tread-depth readings
    drift_s,d       ~ Normal(offset_s - lambda (loss_f - loss_r) / R_0, sigma_radius)

The friction work comes from each drive's own data (speed, force, load, ambient -> tyre
temperature through :mod:`tyrebayes.physics.thermal`), so the uncertainty of C_xr flows into gamma:
wear constrains gamma / C_xr, the stiffness posterior splits it.
"""

from __future__ import annotations

import dataclasses

import arviz as az
import jax
import jax.numpy as jnp
import numpy as np
import numpyro
import numpyro.distributions as dist
from numpyro.infer import MCMC, NUTS, init_to_value, log_likelihood

from ..physics.thermal import StiffnessTemperature, stiffness_at_temperature
from ..simulate.wear import DriveWork, TreadGeometry, WearObservations
from .summary import summarize

TYRE_TYPES = ("winter", "all_season", "summer")


@dataclasses.dataclass(frozen=True)
class WearPriors:
    """Prior scales of the wear model (units in the names).

    ``gamma_median_mm3_per_j`` 0.04 with log-sd 1.0 spans 0.007-0.2 mm^3/J at 90 % (Schallamach
    abrasabilities of tread compounds are O(0.01-0.1) mm^3/J; the ADAC masses imply ~0.03-0.08 for
    this package's duty profile). ``kappa_sd_per_k`` 0.03: a 10 K warmer tyre changes gamma by up
    to ~x1.8 at 2 sd (oxidative wear roughly doubles per 10-20 K, thesis Sec. 6.4 [29]).
    """

    gamma_median_mm3_per_j: float = 0.04
    gamma_log_sd: float = 1.0
    type_spread_log_sd: float = 0.3
    kappa_sd_per_k: float = 0.03
    initial_depth_mm: float = 8.0
    initial_depth_sd_mm: float = 0.5
    depth_noise_scale_mm: float = 0.3
    radius_noise_scale: float = 1e-3
    radius_offset_sd: float = 3e-3


@dataclasses.dataclass(frozen=True)
class WearData:
    """Everything the wear model needs, padded to equal drive counts per set (numpy arrays).

    Build with :func:`build_wear_data`. ``kernel[s, d, a, b]`` (zeros for padded drives),
    ``grid_c[b]``, ``set_type[s]``, ``c_xr_log_mean[s]``/``c_xr_log_sd[s]``; depth readings
    ``depth_set/depth_drive/depth_axle/depth_mm``; radius drift ``drift[s, d]`` with
    ``drift_mask[s, d]``.
    """

    kernel: np.ndarray
    grid_c: np.ndarray
    set_type: np.ndarray
    type_names: tuple[str, ...]
    c_xr_log_mean: np.ndarray
    c_xr_log_sd: np.ndarray
    depth_set: np.ndarray
    depth_drive: np.ndarray
    depth_axle: np.ndarray
    depth_mm: np.ndarray
    drift: np.ndarray
    drift_mask: np.ndarray
    wear_area_mm2: float
    radius_per_depth_over_r0: float

    @property
    def n_sets(self) -> int:
        return int(self.kernel.shape[0])

    @property
    def n_types(self) -> int:
        return len(self.type_names)


def c_xr_lognormal(c_xr) -> tuple[float, float]:
    """(log-mean, log-sd) of C_xr from posterior draws (array) or a ``(mean, sd)`` pair."""
    if isinstance(c_xr, tuple | list) and len(c_xr) == 2:
        mean, sd = float(c_xr[0]), float(c_xr[1])
        if not (mean > 0 and sd >= 0):
            raise ValueError(f"c_xr: expected (mean > 0, sd >= 0), got {c_xr!r}")
        log_sd = float(np.sqrt(np.log1p((sd / mean) ** 2)))
        return float(np.log(mean) - 0.5 * log_sd**2), max(log_sd, 1e-6)
    draws = np.asarray(c_xr, dtype=float).ravel()
    if draws.size < 2 or not np.all(draws > 0):
        raise ValueError(f"c_xr: expected >= 2 positive posterior draws, got {draws.size} values")
    logs = np.log(draws)
    return float(logs.mean()), max(float(logs.std(ddof=1)), 1e-6)


def build_wear_data(
    sets: list[tuple[DriveWork, WearObservations, str, object]],
    use_depth: bool = True,
    use_drift: bool = True,
    geom: TreadGeometry | None = None,
    type_names: tuple[str, ...] | None = None,
) -> WearData:
    """Collect tyre sets ``(drives, observations, tyre_type, c_xr)`` into :class:`WearData`.

    ``c_xr`` is either posterior draws of the set's compensated stiffness or ``(mean, sd)``.
    ``use_depth`` / ``use_drift`` select the observation sources (at least one).
    """
    if not (use_depth or use_drift):
        raise ValueError("build_wear_data: expected use_depth or use_drift, got neither")
    if not sets:
        raise ValueError("build_wear_data: expected at least one tyre set, got none")
    geom = TreadGeometry() if geom is None else geom
    present = [s[2] for s in sets]
    if type_names is None:
        type_names = tuple(t for t in TYRE_TYPES if t in present) + tuple(
            sorted({t for t in present if t not in TYRE_TYPES})
        )
    unknown = sorted(set(present) - set(type_names))
    if unknown:
        raise ValueError(f"build_wear_data: tyre_type not in {type_names}, got {unknown}")
    n_drives = max(int(s[0].kernel_binned.shape[0]) for s in sets)
    grid = np.asarray(sets[0][0].grid_c)
    kernels = np.zeros((len(sets), n_drives, 2, grid.size))
    drift = np.zeros((len(sets), n_drives))
    mask = np.zeros((len(sets), n_drives), dtype=bool)
    d_set, d_drive, d_axle, d_val = [], [], [], []
    log_mean, log_sd = [], []
    for i, (work, obs, _, c_xr) in enumerate(sets):
        k = np.asarray(work.kernel_binned)
        kernels[i, : k.shape[0]] = k
        if use_drift:
            r = np.asarray(obs.radius_drift)
            drift[i, : r.size] = r
            mask[i, : r.size] = True
        if use_depth:
            n = np.asarray(obs.depth_mm).size
            d_set.append(np.full(n, i))
            d_drive.append(np.asarray(obs.depth_drive_index))
            d_axle.append(np.asarray(obs.depth_axle))
            d_val.append(np.asarray(obs.depth_mm))
        m, s = c_xr_lognormal(c_xr)
        log_mean.append(m)
        log_sd.append(s)
    # keep only the temperature bins any drive reached: fewer flops per NUTS step
    used = np.nonzero(kernels.sum(axis=(0, 1, 2)) > 0)[0]
    lo, hi = (used.min(), used.max() + 1) if used.size else (0, grid.size)
    cat = (
        (lambda xs, dt: np.concatenate(xs).astype(dt))
        if use_depth
        else (lambda xs, dt: np.zeros(0, dtype=dt))
    )
    return WearData(
        kernel=kernels[..., lo:hi],
        grid_c=grid[lo:hi],
        set_type=np.array([type_names.index(t) for t in present]),
        type_names=tuple(type_names),
        c_xr_log_mean=np.array(log_mean),
        c_xr_log_sd=np.array(log_sd),
        depth_set=cat(d_set, int),
        depth_drive=cat(d_drive, int),
        depth_axle=cat(d_axle, int),
        depth_mm=cat(d_val, float),
        drift=drift,
        drift_mask=mask,
        wear_area_mm2=float(geom.wear_area_mm2),
        radius_per_depth_over_r0=float(geom.radius_per_depth / geom.outer_radius_mm),
    )


def wear_factor(grid_c, c_xr, kappa, comp: StiffnessTemperature):
    """exp(kappa (T_b - 20)) / C_x(C_xr, T_b): volume per unit gamma_ref and unit kernel."""
    grid = jnp.asarray(grid_c)[None, :]
    c_x = stiffness_at_temperature(jnp.asarray(c_xr)[:, None], grid, comp)
    return jnp.exp(jnp.asarray(kappa)[:, None] * (grid - 20.0)) / c_x


def wear_model(
    data: WearData,
    extended: bool = False,
    priors: WearPriors | None = None,
    comp: StiffnessTemperature | None = None,
):
    """NumPyro model of the module docstring (``extended`` adds kappa per tyre type)."""
    priors = WearPriors() if priors is None else priors
    comp = StiffnessTemperature() if comp is None else comp
    n_sets, n_types = data.n_sets, data.n_types
    with numpyro.plate("types", n_types):
        mu = numpyro.sample(
            "mu_log_gamma",
            dist.Normal(np.log(priors.gamma_median_mm3_per_j), priors.gamma_log_sd),
        )
        if extended:
            kappa_t = numpyro.sample("kappa", dist.Normal(0.0, priors.kappa_sd_per_k))
        else:
            kappa_t = jnp.zeros(n_types)
    set_type = jnp.asarray(data.set_type)
    # pooling needs two sets of one type; with one, (mu, log gamma) is a ridge only priors bound
    pooled = np.bincount(data.set_type, minlength=n_types).max() > 1
    if pooled:
        tau = numpyro.sample("tau", dist.HalfNormal(priors.type_spread_log_sd))
    else:
        tau = numpyro.deterministic("tau", jnp.zeros(()))
    with numpyro.plate("sets", n_sets):
        # centred: each set's readings inform its gamma well, where non-centring makes funnels
        log_gamma = (
            numpyro.sample("log_gamma", dist.Normal(mu[set_type], tau)) if pooled else mu[set_type]
        )
        log_c = numpyro.sample(
            "log_c_xr", dist.Normal(jnp.asarray(data.c_xr_log_mean), jnp.asarray(data.c_xr_log_sd))
        )
        # radius quantities are sampled in units of 1e-3 so all parameters are O(1) for NUTS
        offset = numpyro.sample(
            "radius_offset_permille", dist.Normal(0.0, 1e3 * priors.radius_offset_sd)
        )
        with numpyro.plate("axles", 2, dim=-2):
            d0 = numpyro.sample(
                "initial_depth_mm",
                dist.Normal(priors.initial_depth_mm, priors.initial_depth_sd_mm),
            )
    c_xr = numpyro.deterministic("c_xr", jnp.exp(log_c))
    gamma = numpyro.deterministic("gamma", jnp.exp(log_gamma))
    factor = wear_factor(data.grid_c, c_xr, kappa_t[set_type], comp)  # (s, b)
    volume = gamma[:, None, None] * jnp.einsum("sdab,sb->sda", jnp.asarray(data.kernel), factor)
    loss = jnp.cumsum(volume, axis=1) / data.wear_area_mm2
    loss = jnp.concatenate([jnp.zeros((n_sets, 1, 2)), loss], axis=1)  # after 0..D drives
    if data.depth_mm.size:
        sigma_d = numpyro.sample("sigma_depth_mm", dist.HalfNormal(priors.depth_noise_scale_mm))
        mean = (
            d0[data.depth_axle, data.depth_set]
            - loss[data.depth_set, data.depth_drive, data.depth_axle]
        )
        with numpyro.plate("depth_readings", data.depth_mm.size):
            numpyro.sample("depth", dist.Normal(mean, sigma_d), obs=jnp.asarray(data.depth_mm))
    if data.drift_mask.any():
        sigma_r = numpyro.sample(
            "sigma_radius_permille", dist.HalfNormal(1e3 * priors.radius_noise_scale)
        )
        rows, cols = np.nonzero(data.drift_mask)
        rel = loss[rows, cols + 1, 0] - loss[rows, cols + 1, 1]
        mean = offset[rows] - 1e3 * data.radius_per_depth_over_r0 * rel
        with numpyro.plate("drives", rows.size):
            numpyro.sample(
                "drift_permille",
                dist.Normal(mean, sigma_r),
                obs=jnp.asarray(1e3 * data.drift[rows, cols]),
            )


@dataclasses.dataclass(frozen=True)
class WearFit:
    """A fitted wear model: ArviZ data (with log_likelihood), flat draws and diagnostics."""

    idata: az.InferenceData
    samples: dict
    data: WearData
    extended: bool
    comp: StiffnessTemperature
    diagnostics: dict

    def gamma_summary(self) -> list[dict]:
        """Posterior of gamma_ref per tyre set in the ``{"mean","sd","hdi_90"}`` form [mm^3/J]."""
        return [summarize(self.samples["gamma"][:, i]) for i in range(self.data.n_sets)]


def _init_values(data: WearData, extended: bool, priors: WearPriors) -> dict:
    # Start at the prior centre; explicit values avoid init_to_median's batched trial draws
    # (rank promotion is strict in this package's tests).
    values = {
        "mu_log_gamma": jnp.full(data.n_types, np.log(priors.gamma_median_mm3_per_j)),
        "log_c_xr": jnp.asarray(data.c_xr_log_mean),
        "radius_offset_permille": jnp.zeros(data.n_sets),
        "initial_depth_mm": jnp.full((2, data.n_sets), priors.initial_depth_mm),
        "sigma_depth_mm": jnp.asarray(0.5 * priors.depth_noise_scale_mm),
        "sigma_radius_permille": jnp.asarray(500.0 * priors.radius_noise_scale),
        "tau": jnp.asarray(0.5 * priors.type_spread_log_sd),
        "log_gamma": jnp.full(data.n_sets, np.log(priors.gamma_median_mm3_per_j)),
    }
    if extended:
        values["kappa"] = jnp.zeros(data.n_types)
    return values


def _inference_data(mcmc, data, extended, priors, comp) -> az.InferenceData:
    # Built by hand: az.from_numpyro re-traces the model with random draws, which trips the strict
    # rank promotion this package runs with.
    by_chain = mcmc.get_samples(group_by_chain=True)
    flat = mcmc.get_samples()
    loglik = log_likelihood(wear_model, flat, data, extended, priors, comp)
    n_chains = next(iter(by_chain.values())).shape[0]

    def chains(x):
        x = np.asarray(x)
        return x.reshape((n_chains, -1) + x.shape[1:])

    observed = {}
    if data.depth_mm.size:
        observed["depth"] = data.depth_mm
    if data.drift_mask.any():
        observed["drift_permille"] = 1e3 * data.drift[data.drift_mask]
    stats = {
        k: np.asarray(v)
        for k, v in mcmc.get_extra_fields(group_by_chain=True).items()
        if k == "diverging"
    }
    return az.from_dict(
        posterior={k: np.asarray(v) for k, v in by_chain.items()},
        log_likelihood={k: chains(v) for k, v in loglik.items()},
        observed_data=observed,
        sample_stats=stats,
    )


def fit_wear(
    data: WearData,
    extended: bool = False,
    num_warmup: int = 300,
    num_samples: int = 300,
    num_chains: int = 2,
    seed: int = 0,
    priors: WearPriors | None = None,
    comp: StiffnessTemperature | None = None,
) -> WearFit:
    """NUTS fit of :func:`wear_model`; failures are reported in ``diagnostics`` (never raised).

    ``diagnostics``: ``r_hat_max``, ``ess_min``, ``divergences``, ``converged`` (R-hat <= 1.02,
    ESS >= 50 per chain, no divergences).
    """
    comp = StiffnessTemperature() if comp is None else comp
    priors = WearPriors() if priors is None else priors
    # dense mass: wear data fix gamma / C_xr, so (log gamma, log C_xr) is a correlated ridge
    kernel = NUTS(
        wear_model,
        init_strategy=init_to_value(values=_init_values(data, extended, priors)),
        target_accept_prob=0.95,
        dense_mass=True,
        max_tree_depth=8,
    )
    mcmc = MCMC(
        kernel,
        num_warmup=num_warmup,
        num_samples=num_samples,
        num_chains=num_chains,
        chain_method="sequential",
        progress_bar=False,
    )
    mcmc.run(jax.random.PRNGKey(seed), data, extended, priors, comp)
    idata = _inference_data(mcmc, data, extended, priors, comp)
    samples = {k: np.asarray(v) for k, v in mcmc.get_samples().items()}
    names = ["mu_log_gamma", "gamma", "c_xr"] + (["kappa"] if extended else [])
    divergences = int(np.asarray(mcmc.get_extra_fields()["diverging"]).sum())
    ess_ds = az.ess(idata, var_names=names)
    ess = float(min(np.nanmin(np.asarray(ess_ds[v])) for v in names))
    # R-hat needs two chains (arviz logs a warning otherwise)
    if num_chains > 1:
        rhat_ds = az.rhat(idata, var_names=names)
        r_hat = float(max(np.nanmax(np.asarray(rhat_ds[v])) for v in names))
    else:
        r_hat = float("nan")
    converged = bool(
        (num_chains == 1 or r_hat <= 1.02) and ess >= 50 * num_chains and divergences == 0
    )
    diagnostics = dict(r_hat_max=r_hat, ess_min=ess, divergences=divergences, converged=converged)
    return WearFit(idata, samples, data, extended, comp, diagnostics)


def _draws_gamma_kappa(fit: WearFit, set_index: int | None, type_name: str | None, key):
    """Draws of (gamma_ref, kappa, c_xr) for a fitted set, or for a new set of a type."""
    s = fit.samples
    n = s["tau"].shape[0]
    if set_index is not None:
        t = int(fit.data.set_type[set_index])
        gamma, c_xr = s["gamma"][:, set_index], s["c_xr"][:, set_index]
    else:
        if type_name not in fit.data.type_names:
            raise ValueError(f"type_name: expected one of {fit.data.type_names}, got {type_name!r}")
        t = fit.data.type_names.index(type_name)
        z = np.asarray(jax.random.normal(key, (n,)))
        gamma = np.exp(s["mu_log_gamma"][:, t] + s["tau"] * z)
        c_xr = None
    kappa = s["kappa"][:, t] if fit.extended else np.zeros(n)
    return gamma, kappa, c_xr


def predict_wear_volume(
    fit: WearFit,
    kernel: np.ndarray,
    grid_c: np.ndarray,
    set_index: int | None = None,
    type_name: str | None = None,
    c_xr=None,
    seed: int = 0,
) -> np.ndarray:
    """Posterior draws of worn volume per wheel [mm^3], shape (draws, 2 axles).

    ``kernel[a, b]`` is the binned rho^2 F_z V dt of the driving to predict (e.g. 1000 km of a
    profile at an ambient temperature, :func:`tyrebayes.simulate.wear.profile_kernel`). Give a
    fitted ``set_index``, or a ``type_name`` (a new set of that type, gamma from the type level)
    together with its ``c_xr`` (draws or (mean, sd)).
    """
    key = jax.random.PRNGKey(seed)
    gamma, kappa, c_draws = _draws_gamma_kappa(fit, set_index, type_name, key)
    if c_draws is None:
        if c_xr is None:
            raise ValueError("c_xr: expected draws or (mean, sd) for a new tyre set, got None")
        m, sd = c_xr_lognormal(c_xr)
        c_draws = np.exp(
            m + sd * np.asarray(jax.random.normal(jax.random.fold_in(key, 1), gamma.shape))
        )
    factor = np.asarray(wear_factor(grid_c, c_draws, kappa, fit.comp))  # (n, b)
    return gamma[:, None] * (factor @ np.asarray(kernel).T)


def relative_wear_draws(volume_a: np.ndarray, volume_b: np.ndarray) -> dict:
    """I_rel = I_a / I_b (eq. 4.28) and |I_a - I_b| / max (thesis Sec. 6.2), summarised."""
    a, b = np.asarray(volume_a), np.asarray(volume_b)
    ratio = a / b
    diff = np.abs(a - b) / np.maximum(a, b)
    return {"i_rel": summarize(ratio), "i_rel_thesis": summarize(diff), "draws": ratio}


def high_wear_warning(
    ratio_draws: np.ndarray, threshold: float = 1.25, decision_probability: float = 0.8
) -> dict:
    """Warn "unexpectedly high wear" when P(I_now / I_ref > threshold) >= decision_probability.

    Returns ``{"warning": bool, "probability": p, "threshold": ..., "message": ...}``.
    """
    p = float(np.mean(np.asarray(ratio_draws) > threshold))
    warn = p >= decision_probability
    msg = (
        f"unexpectedly high wear: P(wear rate > {threshold:.2f} x reference) = {p:.2f}"
        if warn
        else f"no wear warning: P(wear rate > {threshold:.2f} x reference) = {p:.2f}"
    )
    return {"warning": warn, "probability": p, "threshold": threshold, "message": msg}
