"""V_max from a fit's lateral posterior: the measured per-axle c_y and μ_y, and their sources.

The posteriors here are built directly (log-normal draws about chosen values), not fitted: the
lateral fit has its own tests, and ``benchmarks/vmax_lateral.py`` runs the whole path on drives
the package did not make. Every prediction uses one vehicle and one draw count, so the lane
change is compiled once for the module.
"""

import dataclasses
import json

import arviz_base as azb
import jax
import numpy as np
import pytest
from jaxtyping import TypeCheckError

from tyrebayes._domain import load_vehicle
from tyrebayes.cli import main
from tyrebayes.inference.diagnostics import diagnose
from tyrebayes.inference.lateral.result import LateralFit
from tyrebayes.inference.result import Fit, load_fit, provenance
from tyrebayes.inference.tyre.adequacy import Adequacy
from tyrebayes.inference.tyre.result import TyreFit
from tyrebayes.inference.vmax import (
    VmaxInputs,
    fit_vmax_inputs,
    lateral_vmax_inputs,
    predict_vmax,
    type_vmax_inputs,
    vmax_draws,
)
from tyrebayes.inference.wear.cornering import cornering_stiffness_from_tyre_fit

VEHICLE = load_vehicle("compact_fwd")
N = 48  # draws per prediction: one compiled program for the module
POSTERIOR_DRAWS = 400
KEY = jax.random.PRNGKey(3)


def _lateral(
    c_f: float, c_r: float, mu: float, *, mu_observed: bool, sd: float = 0.03, problems=()
):
    """A converged lateral fit whose posterior is log-normal about (c_f, c_r, mu)."""
    rng = np.random.default_rng(0)
    z = rng.normal(size=(3, 1, POSTERIOR_DRAWS))
    post = {
        "c_y_front": c_f * np.exp(sd * z[0]),
        "c_y_rear": c_r * np.exp(sd * z[1]),
        "mu_y": mu * np.exp((sd if mu_observed else 0.15) * z[2]),
    }
    post["understeer_gradient"] = (1 / post["c_y_front"] - 1 / post["c_y_rear"]) / 9.81
    data = azb.from_dict({"posterior": post})
    fields = {
        "mu_y_observed": mu_observed,
        "identified": True,
        "cornering_seconds": 200.0,
        "peak_use": 0.9 if mu_observed else 0.5,
        "road_wheel": False,
    }
    fit = Fit(
        data=data,
        diagnostics=diagnose(
            data, method="laplace", optimiser_result="successful", problems=problems
        ),
        kind="lateral",
        provenance=provenance("laplace", "single_track_magic", surface="dry"),
    )
    lateral = LateralFit(fit=fit, **fields)
    fit.data.attrs.update(lateral.attrs())
    return lateral


def _tyre_fit(lateral, *, mu_max: float = 1.0, mu_observed: bool = False) -> TyreFit:
    """A per-tyre fit of C_xr ≈ 35 on dry carrying ``lateral`` (the longitudinal part stubbed)."""
    rng = np.random.default_rng(1)
    post = {
        "c_xr": 35.0 * np.exp(0.05 * rng.normal(size=(1, POSTERIOR_DRAWS))),
        "mu_max": mu_max * np.exp(0.03 * rng.normal(size=(1, POSTERIOR_DRAWS, 1))),
    }
    idata = azb.from_dict({"posterior": post}, dims={"mu_max": ["surface"]})
    return TyreFit(
        idata=idata,
        diagnostics=diagnose(idata, method="fast", optimiser_result="successful"),
        mu_observed={"dry": mu_observed},
        surfaces=("dry",),
        n_samples_used=100,
        model="magic",
        slip_variance_inflation=(1.0,),
        adequacy=Adequacy(True, (), 1.0, 0.1, 0.0, 0.0),
        force_range=0.2,
        secant_stiffness=np.full(4, 30.0),
        provenance=provenance("fast", "magic", ("drive.csv",), vehicle="compact_fwd"),
        lateral=lateral,
        lateral_reason="" if lateral is not None else "lateral: no usable cornering",
    )


def _mean(inputs: VmaxInputs) -> float:
    return float(np.nanmean(predict_vmax(VEHICLE, inputs).v_max_kmh))


def test_measured_axles_move_vmax_the_right_way_and_say_so():
    # the type relation for an all-season tyre of C_xr 35: C_y = 0.40 · 35 = 14 /rad on both axles
    typed = type_vmax_inputs(KEY, 35.0, "all_season", N)
    assert (typed.lateral_source, typed.mu_y_source) == ("type_prior", "type_prior")
    np.testing.assert_array_equal(typed.c_y_front, typed.c_y_rear)
    # measured axles at the type's median with its μ_y (0.95 · 1.0): nearly the type's V_max
    same = lateral_vmax_inputs(KEY, _lateral(14.0, 14.0, 0.95, mu_observed=True), N)
    assert (same.lateral_source, same.mu_y_source) == ("measured", "measured")
    # stiffer axles (both 40 % stiffer): faster; a stiffer rear (understeer) beats a stiffer
    # front (oversteer) of the same stiffnesses: the single-track model's stability
    stiffer = lateral_vmax_inputs(KEY, _lateral(19.6, 19.6, 0.95, mu_observed=True), N)
    stiff_rear = lateral_vmax_inputs(KEY, _lateral(14.0, 19.6, 0.95, mu_observed=True), N)
    stiff_front = lateral_vmax_inputs(KEY, _lateral(19.6, 14.0, 0.95, mu_observed=True), N)
    v_type, v_same = _mean(typed), _mean(same)
    v_stiffer, v_rear, v_front = _mean(stiffer), _mean(stiff_rear), _mean(stiff_front)
    assert abs(v_same - v_type) < 2.0, (v_same, v_type)
    assert v_stiffer > v_type + 3.0, (v_stiffer, v_type)
    assert v_rear > v_front + 2.0, (v_rear, v_front)
    # less grip measured than the type assumes: slower
    slippery = lateral_vmax_inputs(KEY, _lateral(14.0, 14.0, 0.7, mu_observed=True), N)
    assert _mean(slippery) < v_type - 3.0


def test_mu_y_source_falls_back_to_mu_max_then_a_prior_never_the_unobserved_posterior():
    # The lateral posterior's μ_y (0.6) moved off its prior without nearing the peak: the
    # curve's shape moved it, and V_max must not take it.
    unobserved = _lateral(16.0, 18.0, 0.6, mu_observed=False)
    # the tyre fit observed its peak: μ_max replaces the unobserved μ_y, and it is said
    with_mu = fit_vmax_inputs(_tyre_fit(unobserved, mu_max=0.8, mu_observed=True), KEY, N)
    assert (with_mu.lateral_source, with_mu.mu_y_source) == ("measured", "mu_max")
    assert np.mean(with_mu.mu_y) == pytest.approx(0.8, rel=0.02)
    assert "mu_max used" in with_mu.note and "not observed either" not in with_mu.note
    # neither observed: the tyre fit's μ_max, its type's prior on the surface, said so
    prior = fit_vmax_inputs(_tyre_fit(unobserved), KEY, N)
    assert (prior.lateral_source, prior.mu_y_source, prior.surface) == ("measured", "mu_max", "dry")
    assert np.mean(prior.mu_y) == pytest.approx(1.0, rel=0.02)
    assert "not observed either" in prior.note
    # a lateral fit alone: the type relation on dry asphalt where the type is known ...
    typed = lateral_vmax_inputs(KEY, unobserved, N, tyre_type="summer")
    assert typed.mu_y_source == "type_prior"
    assert np.mean(typed.mu_y) == pytest.approx(0.95 * 1.05, rel=0.02)
    # ... else the surface's prior (dry: median 1.0), not the posterior's 0.6
    surface = lateral_vmax_inputs(KEY, unobserved, N)
    assert surface.mu_y_source == "surface_prior" and "dry prior" in surface.note
    assert np.median(surface.mu_y) == pytest.approx(1.0, rel=0.05)
    # every fallback is conditioned on the forces the drive used (here 0.5 × 0.6 = 0.3)
    grippy = _lateral(16.0, 18.0, 2.0, mu_observed=False)  # used: 0.5 × 2.0 = 1.0
    bounded = lateral_vmax_inputs(KEY, grippy, N)
    assert np.min(bounded.mu_y) >= 0.98 * 1.0 and "forces the drive used" in bounded.note
    # the per-axle draws are taken at the same posterior draws (their correlation is kept)
    lateral = _lateral(16.0, 18.0, 1.0, mu_observed=True)
    joint = lateral_vmax_inputs(KEY, lateral, N)
    front, rear = lateral.draws("c_y_front").tolist(), lateral.draws("c_y_rear").tolist()
    pairs = set(zip(front, rear, strict=True))
    assert all((f, r) in pairs for f, r in zip(joint.c_y_front, joint.c_y_rear, strict=True))


def test_no_lateral_path_is_the_type_relation_unchanged():
    fit = _tyre_fit(None)
    inputs = fit_vmax_inputs(fit, KEY, N, "winter")
    assert (inputs.lateral_source, inputs.mu_y_source) == ("type_prior", "type_prior")
    assert inputs.note == "lateral: no usable cornering"
    # the same draws the type path always gave: k_type · C_xr draws and 0.95 μ_type
    again = type_vmax_inputs(KEY, fit.draws("c_xr"), "winter", N)
    np.testing.assert_array_equal(inputs.c_y_front, again.c_y_front)
    np.testing.assert_array_equal(inputs.mu_y, again.mu_y)
    # and the one-stiffness call gives the per-axle call's V_max with equal axles
    one = vmax_draws(VEHICLE, inputs.c_y_front, inputs.mu_y)
    np.testing.assert_array_equal(np.asarray(one), predict_vmax(VEHICLE, inputs).v_max_kmh)
    # a lateral fit that did not converge is not used, and the reason is given
    failed = _lateral(16.0, 18.0, 1.0, mu_observed=True, problems=("optimiser: max_steps",))
    assert not failed.converged
    fallback = fit_vmax_inputs(_tyre_fit(failed), KEY, N)
    assert fallback.lateral_source == "type_prior"
    assert "did not converge" in fallback.note and "max_steps" in fallback.note
    # nor one whose model does not describe its drive
    off = _lateral(16.0, 18.0, 1.0, mu_observed=True)
    reason = "yaw inertia pulled to 1.92x the vehicle file's (+4.3 prior sds)"
    off = LateralFit(
        fit=dataclasses.replace(off.fit, diagnostics=off.fit.diagnostics.with_adequacy([reason])),
        **{
            f: getattr(off, f)
            for f in ("mu_y_observed", "identified", "cornering_seconds", "peak_use", "road_wheel")
        },
    )
    assert off.converged and not off.adequate
    fallback = fit_vmax_inputs(_tyre_fit(off), KEY, N)
    assert fallback.lateral_source == "type_prior"
    assert fallback.note == f"the lateral fit does not describe the drive: {reason}"
    # and the wear evidence's lateral work does not take its stiffnesses either
    usable = _lateral(16.0, 18.0, 1.0, mu_observed=True)
    assert cornering_stiffness_from_tyre_fit(_tyre_fit(usable).fit) is not None
    assert cornering_stiffness_from_tyre_fit(_tyre_fit(off).fit) is None


def test_inputs_refuse_unknown_sources_and_ragged_draws():
    with pytest.raises(ValueError, match="lateral_source"):
        VmaxInputs(np.ones(3), np.ones(3), np.ones(3), "guessed", "measured", "dry")
    with pytest.raises(ValueError, match="one shape"):
        VmaxInputs(np.ones(3), np.ones(2), np.ones(3), "measured", "measured", "dry")
    # the shape check at call time (jaxtyping's, where the suite turns it on)
    with pytest.raises((ValueError, TypeCheckError)):
        vmax_draws(VEHICLE, np.ones(3), np.ones(3), c_y_rear=np.ones(2))


def test_vmax_command_reads_a_lateral_fit_file(tmp_path, capsys):
    lateral = _lateral(19.6, 19.6, 0.95, mu_observed=True)
    path = _tyre_fit(lateral).save(tmp_path / "fit.nc")
    assert main(["vmax", str(path), "--draws", str(N), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["v_max_kmh"]) == {"mean", "sd", "hdi_90"}
    assert (out["lateral_source"], out["mu_y_source"]) == ("measured", "measured")
    assert out["vehicle"] == "compact_fwd"  # the fit's own vehicle
    assert out["c_y_front"]["mean"] == pytest.approx(19.6, rel=0.03)
    # the same fit without its lateral posterior: the type relation, with the reason
    plain = _tyre_fit(None).save(tmp_path / "plain.nc")
    assert main(["vmax", str(plain), "--draws", str(N), "--json"]) == 0
    typed = json.loads(capsys.readouterr().out)
    assert typed["lateral_source"] == "type_prior" and typed["tyre_type"] == "all_season"
    assert typed["note"] == "lateral: no usable cornering"
    assert typed["v_max_kmh"]["mean"] < out["v_max_kmh"]["mean"] - 3.0  # 14 vs 19.6 /rad
    # the saved fit round-trips into the same inputs
    loaded = TyreFit.from_fit(load_fit(path, kind="tyre"))
    assert fit_vmax_inputs(loaded, KEY, N).lateral_source == "measured"
    # text output names the sources; values and a fit together are refused (exit 2)
    assert main(["vmax", str(path), "--draws", str(N)]) == 0
    assert "measured" in capsys.readouterr().out
    assert main(["vmax", str(path), "--c-x", "30"]) == 2
    assert "both FIT and --c-x" in capsys.readouterr().err
    assert main(["vmax"]) == 2


def test_report_section_names_each_sets_sources():
    from tyrebayes.report.content import Report
    from tyrebayes.report.tables import vmax_table
    from tyrebayes.report.vmax_section import vmax_section

    half = N // 2  # the two sets together make one batch of N draws (the module's program)
    measured = lateral_vmax_inputs(KEY, _lateral(19.6, 19.6, 0.95, mu_observed=False), half)
    sets = [
        {"tyre": "measured set", "tyre_type": "", "c_xr": 35.0, "inputs": measured},
        {"tyre": "typed set", "tyre_type": "all_season", "c_xr": 35.0},
    ]
    section = vmax_section("compact_fwd", sets, n_draws=half, extended=False)
    rows = {r["tyre"]: r for r in section.rows}
    assert rows["measured set"]["lateral_source"] == "measured"
    assert rows["measured set"]["mu_y_source"] == "surface_prior"
    assert rows["typed set"]["lateral_source"] == "type_prior"
    assert rows["measured set"]["summary"]["mean"] > rows["typed set"]["summary"]["mean"]
    header, table = vmax_table(Report(title="t", subtitle="", vmax=section))
    assert "lateral parameters" in header
    assert "measured c_y front/rear; surface prior (μ_y not observed)" in table[0]
    assert "k_type · C_xr; 0.95 μ_type" in table[1]


def test_straight_only_set_takes_its_types_fleet_ratio():
    from tests.inference.fleet.test_predict import stub_fleet_fit

    fleet = stub_fleet_fit(loc=(0.6, 0.4, 0.3))
    fit = _tyre_fit(None)  # C_xr ≈ 35, no cornering
    inputs = fit_vmax_inputs(fit, KEY, N, "winter", fleet=fleet)
    assert (inputs.lateral_source, inputs.mu_y_source) == ("fleet_type_ratio", "type_prior")
    assert "no usable cornering" in inputs.note and "20 winter set(s)" in inputs.note
    np.testing.assert_array_equal(inputs.c_y_front, inputs.c_y_rear)
    # C_y = k · C_xr with the fleet's k (0.6), not k_type (0.45)
    assert abs(np.median(inputs.c_y_front) / (0.6 * 35.0) - 1) < 0.1
    typed = fit_vmax_inputs(fit, KEY, N, "winter")
    assert np.median(inputs.c_y_front) > 1.15 * np.median(typed.c_y_front)
    # a type the fleet had no lateral estimate of: its prior, said so
    summer = fit_vmax_inputs(fit, KEY, N, "summer", fleet=fleet)
    assert summer.lateral_source == "fleet_type_ratio" and "(prior)" in summer.note
    # a measured lateral posterior still wins over the fleet's ratio
    measured = fit_vmax_inputs(_tyre_fit(_lateral(16.0, 18.0, 1.0, mu_observed=True)), KEY, N,
                               fleet=fleet)  # fmt: skip
    assert measured.lateral_source == "measured"
    # and V_max runs on it
    assert np.isfinite(_mean(inputs))


def test_vmax_command_takes_a_fleets_ratio_for_a_straight_only_fit(tmp_path, capsys):
    from tests.inference.fleet.test_predict import stub_fleet_fit

    plain = _tyre_fit(None).save(tmp_path / "plain.nc")
    fleet = stub_fleet_fit(loc=(0.6, 0.4, 0.3)).save(tmp_path / "fleet.nc")
    args = ["vmax", str(plain), "--fleet", str(fleet), "--type", "winter", "--draws", str(N)]
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (out["lateral_source"], out["tyre_type"]) == ("fleet_type_ratio", "winter")
    assert out["c_y_front"]["mean"] == pytest.approx(0.6 * 35.0, rel=0.1)
    assert "20 winter set(s)" in out["note"]
    # a fit of another kind as --fleet, or --fleet without a fit: exit 2, one line
    assert main(["vmax", str(plain), "--fleet", str(plain)]) == 2
    assert "expected a fleet fit (fit-fleet), got a tyre fit" in capsys.readouterr().err
    assert main(["vmax", "--fleet", str(fleet), "--c-x", "30", "--mu", "1"]) == 2
    assert "--fleet: expected a per-tyre fit" in capsys.readouterr().err
