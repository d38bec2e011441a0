"""What a report holds: plain numbers and arrays per section, computed before anything is drawn.

Builders in :mod:`tyrebayes.report.sections` fill these from fits; :mod:`~tyrebayes.report.figures`
draws them and :mod:`~tyrebayes.report.html` / :mod:`~tyrebayes.report.markdown` write them. No
renderer computes a number the report states; every number comes from here.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass
class TyreSection:
    """One tyre set's force–slip data and posterior curve.

    ``slip``/``rho`` are the fitted windows with the posterior-mean per-drive offsets removed
    (so they scatter about the tyre's own curve); ``window_surface`` indexes ``surfaces``;
    ``at_limit`` marks ABS windows (their slip is not observed). ``curve`` is
    ``{surface: (slip_grid, q05, q50, q95)}`` of ρ_x = f(σ; C_x, μ_s) over posterior draws.
    """

    name: str
    tyre_type: str | None
    surfaces: tuple[str, ...]
    slip: np.ndarray
    rho: np.ndarray
    window_surface: np.ndarray
    at_limit: np.ndarray
    curve: dict
    summary: dict
    diagnostics: dict
    truth: dict | None = None
    source: str = ""


@dataclasses.dataclass
class LateralSection:
    """One drive's cornering: each axle's force against its slip angle, and the fitted curves.

    ``rho``/``alpha`` map ``"front"``/``"rear"`` to the samples' ρ_y (over the static axle
    load) and the slip angle the steering equation gives them (a partial-residual plot: no car
    measures a slip angle); ``curve`` maps the axle to ``(alpha_grid, q05, q50, q95)`` of
    ρ_y = f(α; c_y, μ_y, C, E) over posterior draws; ``summary`` is the fit's ``to_dict()``.
    """

    name: str
    rho: dict
    alpha: dict
    curve: dict
    summary: dict


@dataclasses.dataclass
class FleetSection:
    """Friction against 1/C_xr by tyre type (thesis Fig. 6.2) with hierarchical and OLS bands.

    ``bands[type] = (c_grid, q05, q50, q95)`` are posterior predictive bands of a new set of the
    type; ``ols`` is ``{"intercept", "slope", "r2", "resid_sd", "n", "band": (c_grid, lo, mid,
    hi)}`` (90 % prediction interval of the thesis' line fitted to all sets).
    """

    surface: str
    outcome: str
    c_xr: np.ndarray
    c_xr_sd: np.ndarray
    mu: np.ndarray
    tyre_type: np.ndarray
    bands: dict
    ols: dict
    parameters: dict
    diagnostics: dict
    n_sets: int
    source: str = ""


@dataclasses.dataclass
class VmaxSection:
    """Predictive V_max of the ISO 3888-2 lane change per tyre set.

    ``rows``: ``{"tyre", "tyre_type", "c_xr", "draws" (km/h), "summary", "measured_lo",
    "measured_hi"}`` (measured bounds NaN for sets without a test), and where the builder set
    them ``"lateral_source"``, ``"mu_y_source"``, ``"surface"``, ``"source_note"``
    (:class:`~tyrebayes.inference.vmax.VmaxInputs`); ``comparison``: driver-free vs extended
    model against the measured Table 6.2 (ELPD, SE), or empty.
    """

    vehicle: str
    rows: list
    comparison: dict


@dataclasses.dataclass
class WearSection:
    """Relative wear against ambient temperature, soft vs stiff tyre, baseline vs extended.

    ``curves[model][tyre] = {"ambient_c", "q05", "q50", "q95", "c_xr", "tyre_type"}`` with the
    wear rate relative to the same tyre at ``reference_c``; ``kappa[type]`` the extended model's
    temperature sensitivity; ``comparison`` PSIS-LOO of the two models.
    """

    reference_c: float
    curves: dict
    kappa: dict
    comparison: dict
    diagnostics: dict
    thesis: dict


@dataclasses.dataclass
class Report:
    """Everything one report states.

    Attributes
    ----------
    title, subtitle : str
        The report's heading.
    tyres, laterals : list
        One section per tyre set's longitudinal and lateral fit.
    fleet, vmax, wear : section or None
        The fleet, V_max and wear sections, where the run made them.
    warnings : list
        Decisions and warnings to show first.
    diagnostics : list
        One row per fit: convergence and adequacy.
    criticism : list
        One entry per criticism run.
    timings : dict
        Step -> ``{"wall_s", "cpu_s"}``.
    notes : list
        Lines a reader needs to read the report right.

    Examples
    --------
    >>> report = Report(title="Tyres of car 7", subtitle="one drive")
    >>> report.title, report.tyres, report.fleet
    ('Tyres of car 7', [], None)
    """

    title: str
    subtitle: str
    tyres: list = dataclasses.field(default_factory=list)
    laterals: list = dataclasses.field(default_factory=list)
    fleet: FleetSection | None = None
    vmax: VmaxSection | None = None
    wear: WearSection | None = None
    warnings: list = dataclasses.field(default_factory=list)
    diagnostics: list = dataclasses.field(default_factory=list)
    criticism: list = dataclasses.field(default_factory=list)
    timings: dict = dataclasses.field(default_factory=dict)  # step -> {"wall_s", "cpu_s"}
    notes: list = dataclasses.field(default_factory=list)
