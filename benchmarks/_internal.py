"""The few internal names of tyrebayes that benchmarks use on purpose, each with the reason.

A benchmark uses the public API (see :mod:`benchmarks`): the names of ``tyrebayes`` itself and
those of the public namespaces of its subpackages. Where a benchmark measures an internal step of
the package (a stage's step, a compiled program, a cache), reports an internal threshold beside
its figures, or manages worker memory the way the batch does, it takes the name from here and
nowhere else: ``from _internal import rss_mb`` in a script, ``from benchmarks._internal import
...`` in a measurement child process of this checkout. ``benchmarks/api_surface.py`` counts the
benchmarks' imports of internal paths outside this module (target 0) and the names held here.

Each name is imported on first use (PEP 562): a script that takes one internal name does not load
the modules of the others (a batch benchmark's peak memory stays its own).

Measurement children that run on the package as of another git revision (``--before REV``) keep
that revision's module paths in their source, since only those are stable across revisions:
:data:`REVISION_CHILDREN` names them, and the count lists them as exclusions.

Examples
--------
>>> from benchmarks import _internal
>>> _internal.INTERNAL["rss_mb"][0]
'tyrebayes.batch.worker_memory'
"""

from __future__ import annotations

import importlib

#: Internal name → (the module that holds it, why a benchmark needs it).
INTERNAL: dict[str, tuple[str, str]] = {
    # batch stages: steps timed or profiled apart, and the worker's memory handling
    "configure_jax": ("tyrebayes.batch.settings", "set JAX up as a fleet-run worker does"),
    "drive_lateral": ("tyrebayes.batch.lateral", "the drive stage's lateral step, timed alone"),
    "LATERAL_METHODS": ("tyrebayes.batch.lateral", "the drive stage's lateral fits, compared"),
    "pad_size": ("tyrebayes.batch.tyre_set_stage", "pad a drive's windows as the stage does"),
    "tyre_set_table": ("tyrebayes.batch.tyre_set_stage", "the tyre-set stage's step, timed"),
    "rss_mb": ("tyrebayes.batch.worker_memory", "resident memory as the workers measure it"),
    "peak_rss_mb": ("tyrebayes.batch.worker_memory", "peak memory as the workers measure it"),
    "drop_compiled_programs": ("tyrebayes.batch.worker_memory", "a worker's memory release"),
    "release_free_memory": ("tyrebayes.batch.worker_memory", "a worker's memory release"),
    "reset_peak_rss": ("tyrebayes.batch.worker_memory", "a task's own peak, as a worker counts it"),
    "_worker_env": ("tyrebayes.batch.cluster", "the environment the cluster gives its workers"),
    "enable_compilation_cache": ("tyrebayes.internal.jax_cache", "the JAX cache the CLI sets up"),
    # tyre fit: its compiled core and passes timed apart, constants reported with the figures
    "DEFAULT_MODEL": ("tyrebayes.inference.tyre.model", "the curve the timed passes use"),
    "curve_slip": ("tyrebayes.inference.tyre.model", "the truth's slip, to score a change"),
    "BLOCK_S": ("tyrebayes.inference.tyre.data", "the window block length, to align truth"),
    "bucket_size": ("tyrebayes.inference.tyre.data", "the padded size whose programs are timed"),
    "deconvolve_forces": ("tyrebayes.inference.tyre.force_density", "the EM step, timed alone"),
    "EXCITATION_FORCE": ("tyrebayes.inference.tyre.adequacy", "threshold shown with the cases"),
    "MIN_EXCITED_WINDOWS": ("tyrebayes.inference.tyre.adequacy", "threshold shown with them"),
    "MAX_C_XR_PRIOR_SDS": ("tyrebayes.inference.tyre.adequacy", "threshold shown with them"),
    "MAX_MU_PRIOR_SDS": ("tyrebayes.inference.tyre.adequacy", "threshold shown with them"),
    "MAX_LABEL_LOG_BAYES_FACTOR": ("tyrebayes.inference.tyre.adequacy", "threshold shown too"),
    # in-car estimator: the Laplace update's parts, timed and counted
    "block_log_likelihood": ("tyrebayes.inference.online.block_likelihood", "timed alone"),
    "block_curvature": ("tyrebayes.inference.online.block_likelihood", "timed alone"),
    "model_sites": ("tyrebayes.inference.online.parameters", "θ to the curve, timed alone"),
    "REVERSION_S": ("tyrebayes.inference.online.config", "the reversion time, to set a case"),
    "run_online_lateral": ("tyrebayes.inference.online.lateral", "the lateral run, block by block"),
    "prior_k_sd": ("tyrebayes.inference.online.lateral_summary", "the prior sd, to score"),
    # lateral fit and criticism
    "G": ("tyrebayes.inference.lateral.data", "the gravity the lateral model divides by"),
    "LATERAL_EFFECTS": ("tyrebayes.inference.lateral.model", "the effects the study switches"),
    "criticize_lateral_effects": ("tyrebayes.criticism.lateral", "the effects' scan, studied"),
    # fits' statistics the benchmarks report beside their figures
    "NETCDF_ENGINE": ("tyrebayes.inference.result", "the fit file's engine, recorded"),
    "hdi": ("tyrebayes.inference.result", "the fit's interval, for truth coverage"),
    "loo": ("tyrebayes.inference.result", "PSIS-LOO as the fits compute it"),
    "ols_interval": ("tyrebayes.inference.ols", "the thesis' OLS line, compared with the fleet"),
    "ols_logpdf": ("tyrebayes.inference.ols", "the OLS line's predictive density"),
    "ols_loo_logpdf": ("tyrebayes.inference.ols", "the OLS line's leave-one-out density"),
    "WORK_SCALE_LOG_SD": ("tyrebayes.inference.wear.history_fit", "its prior sd, recorded"),
}

#: Internal modules whose private parts a benchmark times or patches: name → (module, why).
INTERNAL_MODULES: dict[str, tuple[str, str]] = {
    "tyre_fit": ("tyrebayes.inference.tyre.fit", "its cached Laplace core and passes, timed"),
    "laplace_update": ("tyrebayes.inference.online.laplace_update", "its information count"),
}

#: Measurement children run on the package as of a git revision (``--before REV``), with the
#: reason their source keeps that revision's module paths.
REVISION_CHILDREN: dict[str, str] = {
    "drive_stage_profile._CHILD": "times the drive stage's private step on REV and here",
    "stream_stage_speed._CHILD": "times the drive stage's private step on REV and here",
    "windows_step_speed._CHILD": "times and patches the force-density EM on REV and here",
}

__all__ = sorted([*INTERNAL, *INTERNAL_MODULES])


def __getattr__(name: str) -> object:
    if name in INTERNAL_MODULES:
        value = importlib.import_module(INTERNAL_MODULES[name][0])
    elif name in INTERNAL:
        value = getattr(importlib.import_module(INTERNAL[name][0]), name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value  # later look-ups skip this function
    return value
