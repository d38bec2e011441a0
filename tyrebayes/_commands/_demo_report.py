"""The demo's pipeline: simulate, run the streams, fit, predict, warn, criticise → :class:`Report`.

Sizes (``quick`` / default) are set in :data:`SIZES`; every number the report states is computed
here or in the builders it calls. A helper of the demo command, because it makes its data with
:mod:`tyrebayes.simulate`, which the library never imports: the report's builders
(:mod:`tyrebayes.report.sections`) get fits and data, this module makes them.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import xarray as xr

from .._domain import TYRE_TYPES, load_vehicle
from .._resources import data_dir
from ..criticism import criticize_stream, criticize_table
from ..inference.fleet import fit_fleet
from ..inference.lateral import cornering_observations, fit_lateral
from ..inference.result import Fit
from ..inference.tyre.data import bucket_size, observations_from_features, stack_drives
from ..inference.tyre.fit import fit_tyre
from ..inference.vmax import load_table_6_2
from ..report.content import Report
from ..report.sections import (
    criticism_entry,
    diagnostics_row,
    fleet_section,
    lateral_section,
    tyre_section,
    warning_rows,
)
from ..report.vmax_section import vmax_section
from ..simulate.cornering import simulate_cornering
from ..simulate.drive_io import write_drive
from ..simulate.fleet import (
    AGE_REF_YEARS,
    AGE_STIFFENING_PER_YEAR,
    THESIS_AGED_TYRE_EFFECT,
    simulate_fleet,
)
from ..simulate.tyre_set import simulate_tyre_set_drives
from ..simulate.tyre_spec import TyreSpec
from ..streams import compute_features, read_stream, validate_stream
from ._demo_wear import wear_study


@dataclasses.dataclass(frozen=True)
class DemoSizes:
    """How much the demo simulates and samples."""

    sets_per_type: int
    drive_surfaces: tuple[str, ...]
    drive_seconds: float
    sample_rate_hz: float
    fleet_sets: int
    fleet_draws: int
    vmax_draws: int
    vmax_extended: bool
    real_method: str


SIZES = {
    True: DemoSizes(1, ("dry", "snow"), 60.0, 50.0, 26, 300, 48, False, "fast"),
    False: DemoSizes(2, ("dry", "wet", "snow"), 120.0, 50.0, 60, 500, 200, True, "nuts"),
}
#: The over-aged winter set: years of age (the thesis' two over-aged sets were ~7 years old).
AGED_YEARS = 7.0
REAL_SEGMENT = "comma2k19_rav4_segment.csv"
REAL_VEHICLE = "suv_rav4"
SIM_VEHICLE = "compact_fwd"


def _demo_tyres(sizes: DemoSizes) -> list[tuple[str, str, object]]:
    """(name, type, TyreSpec) of the demo's sets, including the over-aged winter set."""
    out = []
    for t in TYRE_TYPES:
        base = TyreSpec.from_type(t)
        for j in range(sizes.sets_per_type):
            spec = TyreSpec.from_type(t, c_xr=base.c_xr * (1.0 + 0.08 * j))
            out.append((f"{t} {j + 1}", t, spec))
    years = AGED_YEARS - AGE_REF_YEARS
    base = TyreSpec.from_type("winter")
    aged = TyreSpec.from_type(
        "winter",
        c_xr=base.c_xr * (1.0 + AGE_STIFFENING_PER_YEAR * years),
        mu_snow=base.mu_snow - THESIS_AGED_TYRE_EFFECT * years,
        mu_ice=max(base.mu_ice - THESIS_AGED_TYRE_EFFECT * years / 4, 0.05),
    )
    out.append((f"winter aged {AGED_YEARS:g} y", "winter", aged))
    return out


def _with_indices(fit, obs) -> Fit:
    """A tyre fit with per-window drive, surface and temperature (for ``tyrebayes report``)."""
    mask = np.asarray(obs.mask)
    extra = xr.Dataset(
        {
            "drive_index": ("window", np.asarray(obs.drive_index)[mask]),
            "surface_index": ("window", np.asarray(obs.surface_index)[mask]),
            "temperature_c": ("window", np.asarray(obs.temperature_c)[mask]),
        }
    )
    result = fit.fit
    data = result.data.copy()
    data["constant_data"] = xr.DataTree(data["constant_data"].to_dataset().assign(extra))
    return Fit(data=data, diagnostics=result.diagnostics, kind="tyre", provenance=result.provenance)


def run_demo(out_dir: Path, *, quick: bool, seed: int = 0, step_factory=None):
    """Run the demo; returns (Report, {name: Fit to save}).

    The steps, each timed by ``step_factory``'s progress: simulate and stream every tyre set,
    fit them, the real RAV4 segment, cornering, the fleet model, the warnings, V_max, wear and
    the criticism; then the diagnostics, timings and notes.
    """
    sizes = SIZES[bool(quick)]
    tyres = _demo_tyres(sizes)
    steps = step_factory(_step_names(tyres))
    report = _new_report(tyres, sizes, seed, quick)
    fits: dict[str, Fit] = {}
    vehicle = load_vehicle(SIM_VEHICLE)
    prepared = _simulate_sets(tyres, sizes, vehicle, out_dir, seed, steps)
    _fit_sets(prepared, seed, report, fits, steps)

    steps.start("real RAV4 segment")
    _real_segment(sizes, seed, report, fits)
    steps.done()

    steps.start("cornering")
    _cornering(vehicle, seed, report, fits)
    steps.done()

    steps.start("fleet model")
    table, fleet = _fleet_model(sizes, seed, report, fits)
    steps.done()

    steps.start("warnings")
    report.warnings = warning_rows(fleet, [t for t in report.tyres if t.tyre_type], seed=seed)
    steps.done()

    steps.start("V_max")
    report.vmax = _vmax(sizes, seed, report, fits)
    steps.done()

    steps.start("wear")
    report.wear = wear_study(seed, quick=quick)
    steps.done()

    steps.start("criticism")
    _criticism(table, seed, report)
    steps.done()
    steps.close()

    _finish(report, fleet, steps, quick=quick, seed=seed)
    return report, fits


def _step_names(tyres: list[tuple[str, str, object]]) -> list[str]:
    """The demo's steps in order, as its progress shows them."""
    per_set = [f"{s} {n}" for s in ("simulate + stream", "fit") for n, _, _ in tyres]
    return [
        *per_set,
        "real RAV4 segment",
        "cornering",
        "fleet model",
        "warnings",
        "V_max",
        "wear",
        "criticism",
    ]


def _new_report(tyres: list, sizes: DemoSizes, seed: int, quick: bool) -> Report:
    """The report's title and the subtitle that says what the demo simulates."""
    return Report(
        title="tyrebayes demo report" + (" (quick)" if quick else ""),
        subtitle=(
            f"{len(tyres)} simulated tyre sets ({SIM_VEHICLE}, {len(sizes.drive_surfaces)} drives "
            f"of {sizes.drive_seconds:g} s each on {', '.join(sizes.drive_surfaces)}), the real "
            f"comma2k19 RAV4 segment, a {sizes.fleet_sets}-set simulated winter test fleet; "
            f"seed {seed}."
        ),
    )


def _simulate_sets(tyres: list, sizes: DemoSizes, vehicle, out_dir: Path, seed: int, steps):
    """Simulate every set's drives, write them as logs under ``out_dir/logs`` and window them
    through the streams (read, validate, features); returns (name, type, spec, windows,
    surfaces) per set."""
    prepared = []
    for i, (name, tyre_type, spec) in enumerate(tyres):
        steps.start(f"simulate + stream {name}")
        drives = simulate_tyre_set_drives(
            seed * 1000 + i,
            vehicle,
            spec,
            n_drives=len(sizes.drive_surfaces),
            duration_s=sizes.drive_seconds,
            surfaces=sizes.drive_surfaces,
            sample_rate_hz=sizes.sample_rate_hz,
        )
        windows, surfaces = [], []
        for j, (df, truth) in enumerate(drives):
            path = out_dir / "logs" / f"{name.replace(' ', '_')}_{j + 1}_{truth.surface}.parquet"
            write_drive(df, truth, path)
            stream = validate_stream(read_stream(path), vehicle)
            feats = compute_features(stream, vehicle)
            windows.append(observations_from_features(feats, temperature_c=truth.ambient_c))
            surfaces.append(truth.surface)
        prepared.append((name, tyre_type, spec, windows, surfaces))
        steps.done()
    return prepared


def _fit_sets(prepared: list, seed: int, report: Report, fits: dict, steps) -> None:
    """Fit every simulated set (fast), all padded to one size: one compiled fit for all; add
    each fit to ``fits`` and its section, with its truth, to the report."""
    pad = max(bucket_size(sum(len(w) for w in p[3])) for p in prepared)
    for i, (name, tyre_type, spec, windows, surfaces) in enumerate(prepared):
        steps.start(f"fit {name}")
        obs = stack_drives(windows, surfaces, pad_to=pad)
        fit = fit_tyre(obs, method="fast", seed=seed + i)
        key = f"tyre_{name.replace(' ', '_')}"
        fits[key] = _with_indices(fit, obs)
        truth = {"c_xr": spec.c_xr, **{f"mu_{s}": spec.mu_on(s) for s in sorted(set(surfaces))}}
        report.tyres.append(
            tyre_section(
                fits[key],
                name,
                tyre_type=tyre_type,
                truth=truth,
                source=f"simulated, {len(windows)} drives",
            )
        )
        steps.done()


def _real_segment(sizes: DemoSizes, seed: int, report: Report, fits: dict) -> None:
    """Fit the shipped real RAV4 segment (NUTS in the full demo) and add its section."""
    rav4 = load_vehicle(REAL_VEHICLE)
    stream = validate_stream(read_stream(data_dir() / REAL_SEGMENT), rav4)
    feats = compute_features(stream, rav4)
    obs = stack_drives([observations_from_features(feats)], ["dry"])
    kw = (
        {"num_chains": 2, "num_warmup": 300, "num_samples": 500}
        if sizes.real_method == "nuts"
        else {}
    )
    fit = fit_tyre(obs, method=sizes.real_method, seed=seed, **kw)
    fits["tyre_rav4_real"] = _with_indices(fit, obs)
    report.tyres.append(
        tyre_section(
            fits["tyre_rav4_real"],
            "RAV4 real segment",
            tyre_type=None,
            source=(
                f"shipped {REAL_SEGMENT}; assumes the {REAL_VEHICLE} preset (FWD, nominal "
                "wheel radius 0.35 m), dry asphalt, a tyre temperature of 20 °C (the log has "
                "no temperature channel), the dashcam IMU's scale estimated against the wheel "
                "speeds; "
                "no ABS, so μ_max stays at its prior"
            ),
        )
    )


def _cornering(vehicle, seed: int, report: Report, fits: dict) -> None:
    """Fit four minutes of simulated cornering and add its lateral section."""
    frame, corner_truth = simulate_cornering(vehicle, duration_s=240.0, seed=seed + 5)
    lateral = fit_lateral(cornering_observations(frame, vehicle), seed=seed)
    fits["lateral_cornering"] = lateral.fit
    report.laterals.append(
        lateral_section(
            lateral,
            f"simulated cornering ({SIM_VEHICLE}, true c_y {corner_truth.c_y_front:g} / "
            f"{corner_truth.c_y_rear:g})",
        )
    )


def _fleet_model(sizes: DemoSizes, seed: int, report: Report, fits: dict):
    """Simulate the winter test fleet on snow and fit the fleet model; returns the fleet table
    and its fit (the warnings and the criticism use them)."""
    table, _truth = simulate_fleet(seed + 7, sizes.fleet_sets, surface="snow", effects=("age",))
    fleet = fit_fleet(
        table, seed=seed, num_warmup=sizes.fleet_draws, num_samples=sizes.fleet_draws, num_chains=2
    )
    fits["fleet"] = fleet
    report.fleet = fleet_section(
        fleet,
        surface="snow",
        seed=seed,
        source=f"simulated winter test fleet, {sizes.fleet_sets} sets",
    )
    return table, fleet


def _vmax(sizes: DemoSizes, seed: int, report: Report, fits: dict):
    """The V_max section: the thesis' Table 6.2 sets and the demo's simulated sets (their C_xr
    draws)."""
    table62 = load_table_6_2()
    vsets = [
        {
            "tyre": r.tyre,
            "tyre_type": r.tyre_type,
            "c_xr": float(r.c_xr),
            "measured_lo": float(r.v_max_kmh),
        }
        for r in table62.itertuples()
    ]
    for t in report.tyres:
        if t.tyre_type:
            c = np.asarray(fits[f"tyre_{t.name.replace(' ', '_')}"].posterior["c_xr"]).ravel()
            vsets.append({"tyre": f"demo: {t.name}", "tyre_type": t.tyre_type, "c_xr": c})
    return vmax_section(
        "compact_fwd", vsets, n_draws=sizes.vmax_draws, seed=seed, extended=sizes.vmax_extended
    )


def _criticism(table, seed: int, report: Report) -> None:
    """Criticise the fleet table and the real segment."""
    report.criticism.append(
        criticism_entry(
            "the winter test fleet (mu on snow vs 1/C_xr)", criticize_table(table, "mu", seed=seed)
        )
    )
    report.criticism.append(
        criticism_entry(
            "the real RAV4 segment (rho_x = C_x (sigma_x - s0))",
            criticize_stream(data_dir() / REAL_SEGMENT, REAL_VEHICLE, seed=seed),
        )
    )


def _finish(report: Report, fleet, steps, *, quick: bool, seed: int) -> None:
    """Every fit's diagnostics in one table, the steps' timings, and how to reproduce."""
    report.diagnostics = [{"fit": f"tyre: {t.name}", **t.diagnostics} for t in report.tyres]
    report.diagnostics.append(diagnostics_row(fleet.diagnostics, "fleet model"))
    for m, d in report.wear.diagnostics.items():
        report.diagnostics.append({"fit": f"wear {m}", **d})
    ext = report.vmax.comparison.get("extended")
    if ext:
        report.diagnostics.append(ext["diagnostics"])
    report.timings = {
        k: {"wall_s": v, "cpu_s": steps.cpu.get(k, float("nan"))} for k, v in steps.timings.items()
    }
    report.notes.append(
        "Reproduce: tyrebayes demo" + (" --quick" if quick else "") + f" --seed {seed}; "
        "re-render from the saved fits: tyrebayes report fits/*.nc --out DIR."
    )
