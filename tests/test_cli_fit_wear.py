"""``tyrebayes fit-wear``: end to end on a few tiny drives; bad inputs exit 2 with one line."""

import json

import numpy as np
import pandas as pd
import pytest

from tyrebayes.cli import main
from tyrebayes.inference.result import load_fit

from .inference.test_wear_history import synthetic_table


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err


@pytest.fixture(scope="module")
def tiny_year(tmp_path_factory):
    from tyrebayes.simulate.wear_history import simulate_wear_year

    folder = tmp_path_factory.mktemp("year")
    truth = simulate_wear_year(
        4,
        folder,
        n_drives=8,
        drive_s=90.0,
        km_per_year=4000.0,
        gamma_mm3_per_j=0.2,
        rotation_at=0.5,
        replacement_at=None,
    )
    return folder, truth


def test_streams_end_to_end(tiny_year, tmp_path, capsys):
    folder, truth = tiny_year
    fit_path = tmp_path / "wear.nc"
    argv = ["fit-wear", *truth.stream_paths, "--vehicle", "compact_fwd", "--samples", "60"]
    code = main([*argv, "--out", str(fit_path), "--json"])
    assert code in (0, 3)  # 3: not converged at 60 draws; the summary is printed either way
    out = json.loads(capsys.readouterr().out)
    assert out["n_drives"] == 8
    assert out["history_km"] > 3000
    for key in ("gamma", "gamma_work", "km_to_3mm", "km_to_1_6mm", "depth_curve", "high_wear"):
        assert key in out
    assert out["km_to_1_6mm"]["mean"] > out["km_to_3mm"]["mean"]
    assert isinstance(out["high_wear"]["warning"], bool)
    # the drives' own lateral fits are tried first: 90 s drives corner too little for one
    assert out["lateral_work"]["cornering_stiffness_source"] == "type_prior"
    assert out["lateral_work"]["note"].startswith("no usable lateral fit among the first 5")
    assert out["lateral_work"]["share_of_work"]["rear"] > 0.5  # the drives corner
    fit = load_fit(fit_path, kind="wear_history")
    assert "predictions" in fit.data.attrs


def test_a_fit_that_did_not_converge_exits_3_and_is_still_written(
    tiny_year, tmp_path, capsys, monkeypatch
):
    """The one fit contract: exit 3 with the reason on stderr, the fit file written anyway."""
    import dataclasses

    from tyrebayes.inference.wear import history_fit

    real = history_fit.fit_wear_history

    def not_converged(*args, **kwargs):
        fit = real(*args, **kwargs)
        failed = dataclasses.replace(
            fit.diagnostics, converged=False, reasons=("R-hat 1.500 > 1.01",)
        )
        return dataclasses.replace(fit, diagnostics=failed)

    monkeypatch.setattr(history_fit, "fit_wear_history", not_converged)
    _, truth = tiny_year
    fit_path = tmp_path / "failed.nc"
    argv = ["fit-wear", *truth.stream_paths, "--vehicle", "compact_fwd", "--samples", "60"]
    assert main([*argv, "--out", str(fit_path)]) == 3
    assert "did not converge: R-hat 1.500" in capsys.readouterr().err
    assert not load_fit(fit_path, kind="wear_history").diagnostics.converged


@pytest.mark.slow
def test_the_summary_table_gives_the_same_answer(tiny_year, capsys):
    """The same drives as a fleet-run summary table (shuffled: drive_order restores it)."""
    _, truth = tiny_year
    argv = ["fit-wear", *truth.stream_paths, "--vehicle", "compact_fwd", "--samples", "60"]
    main([*argv, "--json"])
    out = json.loads(capsys.readouterr().out)
    from tyrebayes._domain import load_vehicle
    from tyrebayes.streams.wear_evidence_table import wear_evidence_table

    table = wear_evidence_table(truth.stream_paths, load_vehicle("compact_fwd"), "compact_fwd")
    summary = truth.stream_paths[0].rsplit("/", 1)[0] + "/drives.parquet"
    table.sample(frac=1.0, random_state=0).to_parquet(summary)
    code = main(["fit-wear", summary, "--vehicle", "compact_fwd", "--samples", "60", "--json"])
    again = json.loads(capsys.readouterr().out)
    assert code in (0, 3)
    assert again["gamma_work"]["mean"] == pytest.approx(out["gamma_work"]["mean"], rel=1e-6)


def test_a_summary_tables_lateral_work_takes_its_drives_lateral_estimates(tiny_year, capsys):
    """A fleet run's drive summaries carry each drive's c_y: fit-wear puts the lateral work on
    them, per tyre set (a set without one keeps the type prior); --type-prior-cornering not."""
    from tyrebayes._commands.fit_wear import drive_table
    from tyrebayes._domain import load_vehicle
    from tyrebayes.streams.wear_evidence_table import wear_evidence_table

    _, truth = tiny_year
    table = wear_evidence_table(truth.stream_paths, load_vehicle("compact_fwd"), "compact_fwd")
    table = table.drop(columns="cornering_stiffness_source")  # as a fleet run writes it
    table["tyre_set_id"] = ["a"] * 4 + ["b"] * 4
    table["c_y"], table["c_y_log_sd"] = [22.0] * 4 + [np.nan] * 4, [0.1] * 4 + [np.nan] * 4
    table["c_y_front"], table["c_y_rear"] = [20.0] * 4 + [np.nan] * 4, [24.2] * 4 + [np.nan] * 4
    table["lateral_reason"] = [""] * 4 + ["lateral: no usable cornering"] * 4
    summary = truth.stream_paths[0].rsplit("/", 1)[0] + "/summaries_with_lateral.parquet"
    table.to_parquet(summary)
    own, note = drive_table([summary], "compact_fwd", fit_cornering=True)
    assert note == "c_y from the drives' lateral estimates (1 of 2 tyre set(s))"
    assert own["cornering_stiffness_source"].tolist() == ["drive_lateral"] * 4 + ["type_prior"] * 4
    ratio = own["work_y_front_j"].to_numpy() / table["work_y_front_j"].to_numpy()
    old, new = (t["cornering_stiffness_front_per_rad"].to_numpy() for t in (table, own))
    assert ratio[:4] == pytest.approx(old[:4] / new[:4])
    assert new[0] == pytest.approx(20.0, rel=0.05)  # the drives' front c_y, about
    assert ratio[4:] == pytest.approx(1.0)
    kept, note = drive_table([summary], "compact_fwd")
    assert note == "" and (kept["work_y_front_j"] == table["work_y_front_j"]).all()
    code = main(["fit-wear", summary, "--vehicle", "compact_fwd", "--samples", "60", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code in (0, 3)
    assert out["lateral_work"]["cornering_stiffness_source"] == "drive_lateral+type_prior"
    assert out["lateral_work"]["note"].startswith("c_y from the drives' lateral estimates")


def test_the_type_prior_and_a_tyre_fit_together_are_bad_input(tiny_year, tmp_path, capsys):
    _, truth = tiny_year
    argv = ["fit-wear", *truth.stream_paths, "--vehicle", "compact_fwd"]
    code = main([*argv, "--type-prior-cornering", "--tyre-fit", str(tmp_path / "tyre.nc")])
    assert code == 2
    assert "--type-prior-cornering: expected no --tyre-fit" in _one_line_error(capsys)


def test_a_history_of_one_drive(tiny_year, capsys):
    _, truth = tiny_year
    code = main(["fit-wear", truth.stream_paths[0], "--vehicle", "compact_fwd"])
    assert code == 2
    assert "at least 2 drives" in _one_line_error(capsys)


def test_drives_of_different_vehicles(tmp_path, capsys):
    table, _ = synthetic_table()
    full = _summary(table)
    full.loc[3, "vehicle"] = "suv_rav4"
    path = tmp_path / "drives.csv"
    full.to_csv(path, index=False)
    code = main(["fit-wear", str(path), "--vehicle", "compact_fwd"])
    assert code == 2
    assert "one vehicle" in _one_line_error(capsys)


def test_readings_that_increase(tmp_path, capsys):
    table, _ = synthetic_table()
    path = tmp_path / "drives.csv"
    _summary(table).to_csv(path, index=False)
    readings = tmp_path / "readings.csv"
    pd.DataFrame(
        {"odometer_km": [500.0, 2500.0], "axle": ["rear", "rear"], "depth_mm": [7.0, 7.9]}
    ).to_csv(readings, index=False)
    code = main(["fit-wear", str(path), "--vehicle", "compact_fwd", "--tread-depth", str(readings)])
    assert code == 2
    assert "do not increase" in _one_line_error(capsys)


def _summary(table: pd.DataFrame) -> pd.DataFrame:
    from tyrebayes.streams.wear_evidence import WEAR_EVIDENCE_COLUMNS

    full = table.copy()
    for col in WEAR_EVIDENCE_COLUMNS:
        if col not in full:
            full[col] = np.nan
    full["vehicle"] = "compact_fwd"
    full["drive_id"] = [f"d{i}" for i in range(len(full))]
    full["drive_order"] = np.arange(len(full))
    return full


def test_a_manifest_is_read(tiny_year, tmp_path, capsys):
    """A .txt manifest of one path is a history of one drive; a CSV one names other cars."""
    _, truth = tiny_year
    txt = tmp_path / "drives.txt"
    txt.write_text(f"# one drive\n{truth.stream_paths[0]}\n")
    assert main(["fit-wear", str(txt), "--vehicle", "compact_fwd"]) == 2
    assert "at least 2 drives" in _one_line_error(capsys)
    csv = tmp_path / "drives.csv"
    pd.DataFrame(
        {"path": list(truth.stream_paths[:2]), "vehicle": ["compact_fwd", "suv_rav4"]}
    ).to_csv(csv, index=False)
    assert main(["fit-wear", str(csv), "--vehicle", "compact_fwd"]) == 2
    assert "one vehicle" in _one_line_error(capsys)


def test_a_tyre_fit_with_a_summary_table_is_bad_input(tmp_path, capsys):
    """A summary table's lateral work was computed with its own c_y: --tyre-fit cannot apply."""
    table, _ = synthetic_table()
    path = tmp_path / "summary.csv"
    _summary(table).to_csv(path, index=False)
    fake = tmp_path / "tyre.nc"
    fake.write_bytes(b"not a fit")
    code = main(["fit-wear", str(path), "--vehicle", "compact_fwd", "--tyre-fit", str(fake)])
    assert code == 2
    assert "tyre" in _one_line_error(capsys)
