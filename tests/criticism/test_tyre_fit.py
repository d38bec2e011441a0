"""Criticism of a per-tyre fit file: slip residuals against the conditions stored with the fit.

Marked slow: the fixture compiles and runs a per-tyre fit (minutes on 2 shared cores when run
alone). The default suite's end-to-end check of ``criticize`` on a fit file uses a fleet fit
(tests/test_cli_criticize.py).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from tyrebayes.cli import main
from tyrebayes.criticism import criticize_tyre_fit
from tyrebayes.inference import fit_tyre
from tyrebayes.inference.tyre.data import observations_from_features, stack_drives

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def tyre_fit_file(tmp_path_factory):
    """The 5-minute drive of tests/inference/tyre/test_fit.py (same shape: no new compilation),
    fitted on the fast path and saved."""
    from tyrebayes._domain import load_vehicle
    from tyrebayes.simulate.drive import simulate_drive
    from tyrebayes.simulate.profiles import ProfileOptions
    from tyrebayes.streams import compute_features, validate_stream

    vehicle = load_vehicle("compact_fwd")
    df, _ = simulate_drive(
        3, vehicle, "summer", duration_s=300.0, profile=ProfileOptions(n_abs_events=1)
    )
    features = compute_features(validate_stream(df, vehicle), vehicle)
    obs = stack_drives([observations_from_features(features)], ["dry"])
    path = tmp_path_factory.mktemp("tyre") / "fit.nc"
    fit_tyre(obs, method="fast").save(path)
    return path


def test_tyre_fit_file_stores_window_conditions_and_is_criticised(tyre_fit_file):
    with xr.open_datatree(tyre_fit_file, engine="netcdf4") as tree:
        stored = set(tree["constant_data"].data_vars)
    assert {"at_limit", "temperature_c", "drive_index", "block_index", "surface_index"} <= stored
    result = criticize_tyre_fit(tyre_fit_file)
    names = {c.covariate for c in result.candidates}
    # The drive's temperature is constant here (20 °C default): no temperature candidate.
    assert {"force_rho", "time_in_drive_s"} <= names
    for c in result.candidates:
        assert 0.0 < c.p_value <= 1.0 and c.p_value <= c.q_value + 1e-12
        assert not c.found or c.elpd_gain > 0  # the rule's guarantee
    assert "lag-1 autocorrelation of slip residuals" in result.ppc
    assert np.isfinite(result.baseline.elpd)
    assert result.notes[0].startswith("fitted model: per-tyre fit")


def test_criticize_cli_on_a_tyre_fit_file(tyre_fit_file, capsys):
    assert main(["criticize", str(tyre_fit_file), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {c["covariate"] for c in out["candidates"]} >= {"force_rho", "time_in_drive_s"}
    assert all(c["elpd_gain"] > 0 for c in out["candidates"] if c["found"])
