"""Report sections from hand-made fits: offsets removed, curves at the posterior."""

from __future__ import annotations

import arviz_base as azb
import numpy as np
import pytest

from tyrebayes.inference.result import Fit, Provenance, diagnose
from tyrebayes.report.sections import diagnostics_row, tyre_section


def _idata(with_indices: bool) -> Fit:
    rng = np.random.default_rng(1)
    n_draws, n_win = 200, 300
    drive = np.repeat([0, 1], n_win // 2)
    s0 = np.array([0.002, -0.001])
    gain = np.array([1.0, 1.1])
    true_slip = rng.uniform(-0.002, 0.006, n_win)
    posterior = {
        "c_xr": rng.normal(30.0, 0.5, (1, n_draws)),
        "c_x": rng.normal(30.0, 0.5, (1, n_draws)),
        "mu_max": rng.normal(0.9, 0.05, (1, n_draws, 1)),
        "slip_offset": np.broadcast_to(s0, (1, n_draws, 2)).copy(),
        "force_gain": np.broadcast_to(gain, (1, n_draws, 2)).copy(),
    }
    groups = {
        "posterior": posterior,
        "observed_data": {
            "slip_obs": true_slip + s0[drive],
            "rho_obs": 30.0 * true_slip * gain[drive],
        },
    }
    if with_indices:
        groups["constant_data"] = {"drive_index": drive, "surface_index": np.zeros(n_win, int)}
    data = azb.from_dict(
        groups,
        dims={"mu_max": ["surface"], "slip_offset": ["drive"], "force_gain": ["drive"]},
        coords={"surface": ["dry"]},
    )
    diagnostics = diagnose(data, method="laplace", var_names=["c_xr"], optimiser_result="n/a")
    return Fit(
        data=data,
        diagnostics=diagnostics,
        kind="tyre",
        provenance=Provenance(method="laplace", model="brush"),
    )


def test_tyre_section_removes_offsets_and_gains() -> None:
    fit = _idata(with_indices=True)
    sec = tyre_section(fit, "t", tyre_type="winter")
    # offset and gain removed: the windows lie on rho = 30 sigma
    np.testing.assert_allclose(sec.rho, 30.0 * sec.slip, atol=1e-9)
    grid, lo, mid, hi = sec.curve["dry"]
    slope = np.polyfit(grid[np.abs(grid) < 0.002], mid[np.abs(grid) < 0.002], 1)[0]
    assert abs(slope - 30.0) < 1.5 and np.all(lo <= mid) and np.all(mid <= hi)
    assert abs(sec.summary["c_xr"]["mean"] - 30.0) < 0.2


def test_tyre_section_without_indices_uses_mean_offsets() -> None:
    sec = tyre_section(_idata(with_indices=False), "t")
    assert sec.slip.shape == sec.rho.shape == (300,)
    assert np.all(np.isfinite(sec.slip)) and sec.diagnostics["chains"] == 1
    # The section shows the fit's own diagnostics (here: an optimiser that did not report).
    np.testing.assert_equal(
        sec.diagnostics, diagnostics_row(_idata(with_indices=False).diagnostics)
    )
    assert not sec.diagnostics["converged"] and "optimiser: n/a" in sec.diagnostics["reason"]


def test_tyre_section_refuses_another_kind_of_fit() -> None:
    fit = _idata(with_indices=True)
    fleet = Fit(data=fit.data, diagnostics=fit.diagnostics, kind="fleet", provenance=fit.provenance)
    with pytest.raises(ValueError, match="expected a tyre fit, got a fleet fit"):
        tyre_section(fleet, "t")


def test_shaped_curves_are_the_brush_at_shape_one_and_straighter_above():
    from tyrebayes.physics.tyre import brush_longitudinal
    from tyrebayes.report.sections import _shaped_curves

    slip = np.linspace(-0.12, 0.12, 61)
    c_x, mu = np.array([30.0, 45.0]), np.array([1.0, 0.8])
    brush = np.asarray(brush_longitudinal(slip[None, :], c_x[:, None], mu[:, None], 1.0))
    np.testing.assert_allclose(_shaped_curves(slip, c_x, mu, np.ones(2)), brush, atol=2e-3)
    # p = 2 bends later: more force than the brush at every slip between zero and the peak.
    later = _shaped_curves(slip, c_x, mu, np.full(2, 2.0))
    inside = (slip > 0.005) & (slip < 0.9 * 3 * mu.min() / c_x.max())
    assert np.all(later[:, inside] > brush[:, inside])
