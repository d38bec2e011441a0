"""Settings of a fleet run, and the per-process set-up its tasks need (JAX, float64, cache)."""

from __future__ import annotations

import dataclasses

from ..inference.result import PACKAGE_VERSION
from ..internal.jax_cache import enable_compilation_cache

METHODS = ("fast", "nuts")


@dataclasses.dataclass(frozen=True)
class RunSettings:
    """What a fleet run's results depend on besides its inputs (kept beside every output).

    Attributes
    ----------
    method : str
        Tyre-set fit: ``"fast"`` (MAP + Laplace) or ``"nuts"``; it sets the drives' lateral fit
        too (:attr:`lateral_method`).
    model : str
        Tyre-curve model of the tyre-set fit (:data:`tyrebayes.inference.tyre.model.CURVE_MODELS`).
    load_sensitivity : bool
        Fit the tyre sets with the load sensitivity of the slip stiffness
        (:meth:`tyrebayes.inference.tyre.model.TyrePriors.with_load_sensitivity`).
    seed : int
        Randomness of the fits.
    window_s : float
        Window length of the windowed observations [s].
    pointwise : bool
        Keep each tyre set's per-window log-likelihood and posterior predictive draws in its fit
        file. Off by default: they are most of a file (37-50 MB per set in the ``fleet_run``
        benchmark's reduced and mid sizes) and their computation part of every fit, and
        :func:`tyrebayes.inference.tyre.predictive.with_pointwise` (what ``criticize`` calls)
        recomputes them from the file when wanted.
    jax_cache : str
        Folder of JAX's persistent compilation cache, shared by every worker ("" = none).
    memory_budget_mb : float
        What a worker aims to keep each task's peak memory under [MB]: it drops the programs it
        compiled for earlier tasks when keeping them would take the next task past this
        (:mod:`.worker_memory`). The issue's 1.5 GB per worker by default. Results do not
        depend on it.
    lateral : bool
        Fit each drive's cornering (:func:`tyrebayes.batch.lateral.drive_lateral`) and give each
        tyre set its c_y, which the fleet model's per-type ratio c_y / C_xr learns from. A drive
        without usable cornering costs a fraction of a second; one with it, a lateral fit
        (:attr:`lateral_method`).

    Examples
    --------
    >>> RunSettings().method, RunSettings().seed
    ('fast', 0)
    """

    method: str = "fast"
    model: str = "magic"
    load_sensitivity: bool = False
    seed: int = 0
    window_s: float = 0.25
    pointwise: bool = False
    jax_cache: str = ""
    memory_budget_mb: float = 1536.0
    lateral: bool = True

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"method: expected one of {METHODS}, got {self.method!r}")
        if not self.window_s > 0:
            raise ValueError(f"window_s: expected > 0, got {self.window_s}")
        if not self.memory_budget_mb > 0:
            raise ValueError(f"memory_budget_mb: expected > 0, got {self.memory_budget_mb}")

    @property
    def lateral_method(self) -> str:
        """The drives' lateral fit (:func:`tyrebayes.batch.lateral.drive_lateral`): the in-car
        estimator's moments for a fast run (milliseconds per drive), the batch fit's Laplace
        (seconds per hour of driving, a compilation per new length) for a NUTS run.

        Examples
        --------
        >>> RunSettings().lateral_method, RunSettings(method="nuts").lateral_method
        ('moments', 'laplace')
        """
        return "moments" if self.method == "fast" else "laplace"

    def drive_settings(self) -> dict:
        """What a drive's outputs depend on: the window length, and the lateral fit's method
        and seed (the seed only through the Laplace fit's draws)."""
        lateral = (
            {"lateral": True, "lateral_method": self.lateral_method, "seed": self.seed}
            if self.lateral
            else {"lateral": False}
        )
        return {"stage": "drive", "window_s": self.window_s, **lateral, "version": PACKAGE_VERSION}

    def tyre_set_settings(self) -> dict:
        return {
            "stage": "tyre_set",
            "method": self.method,
            "model": self.model,
            "load_sensitivity": self.load_sensitivity,
            "seed": self.seed,
            "pointwise": self.pointwise,
            "version": PACKAGE_VERSION,
        }

    def fleet_settings(self) -> dict:
        return {"stage": "fleet", "seed": self.seed, "version": PACKAGE_VERSION}


def configure_jax(cache_dir: str = "") -> None:
    """Float64 (slip is ~1e-3 with noise ~1e-4) and the shared compilation cache, per process.

    Idempotent; every task calls it first, so workers of any cluster are set up alike. The
    persistent cache keeps compiled fits on disk: a worker that starts after another compiled the
    same shapes loads them instead of compiling (a minute per shape on one core).
    """
    import jax

    jax.config.update("jax_enable_x64", True)
    if cache_dir and jax.config.jax_compilation_cache_dir != cache_dir:
        enable_compilation_cache(cache_dir)
