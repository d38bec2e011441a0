"""Report sections from hand-made InferenceData: offsets removed, curves at the posterior."""

from __future__ import annotations

import arviz as az
import numpy as np

from tyrebayes.report.sections import is_fleet_fit, is_tyre_fit, tyre_section


def _idata(with_indices: bool) -> az.InferenceData:
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
    kw = {
        "posterior": posterior,
        "observed_data": {
            "slip_obs": true_slip + s0[drive],
            "rho_obs": 30.0 * true_slip * gain[drive],
        },
        "dims": {"mu_max": ["surface"], "slip_offset": ["drive"], "force_gain": ["drive"]},
        "coords": {"surface": ["dry"]},
    }
    if with_indices:
        kw["constant_data"] = {"drive_index": drive, "surface_index": np.zeros(n_win, int)}
    return az.from_dict(**kw)


def test_tyre_section_removes_offsets_and_gains() -> None:
    idata = _idata(with_indices=True)
    assert is_tyre_fit(idata) and not is_fleet_fit(idata)
    sec = tyre_section(idata, "t", tyre_type="winter")
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
