"""The drive-history prediction's typed result: its JSON object and its checks."""

import numpy as np
import pytest

from tyrebayes.inference.wear.changepoint import TyreChanges
from tyrebayes.inference.wear.history_predict import LIMITS_MM, WearHistoryPrediction


def _prediction(km_to_limit_km: np.ndarray, **changes) -> WearHistoryPrediction:
    rng = np.random.default_rng(0)
    n = km_to_limit_km.shape[-1]
    tyre_changes = TyreChanges(
        np.array([3]), ("rotation",), np.array([0.9]), np.array([5.0]), 3.0, 0.01
    )
    fields = dict(
        gamma_mm3_per_j=rng.lognormal(np.log(0.02), 0.1, n),
        gamma_work_mm3_per_j=rng.lognormal(np.log(0.02), 0.1, n),
        kappa_per_k=rng.normal(0.02, 0.005, n),
        lateral_source="type_prior",
        lateral_log_sd=0.5,
        lateral_share_of_work=(0.3, 0.8),
        lateral_work_scale=rng.lognormal(0.0, 0.2, (n, 2)),
        wear_mm_per_km=rng.lognormal(np.log(1e-4), 0.1, (n, 2)),
        depth_now_mm=rng.normal(6.0, 0.2, (n, 2)),
        km_to_limit_km=km_to_limit_km,
        depth_curve_km_ahead=np.linspace(0.0, 60000.0, 13),
        depth_curve_quantiles_mm=np.tile(np.linspace(6.0, 0.0, 13), (3, 1)),
        g_per_1000km_car_set=rng.normal(120.0, 5.0, n),
        reference_g_per_1000km=100.0,
        tyre_type="summer",
        tyre_changes=tyre_changes,
        tyre_change_odometer_km=np.array([4200.0]),
        n_drives=12,
        history_km=9000.0,
    )
    return WearHistoryPrediction(**{**fields, **changes})


def test_to_dict_is_the_commands_object():
    km = np.stack([np.full(200, -500.0), np.full(200, 30000.0)])  # 3 mm passed, 1.6 mm ahead
    pred = _prediction(km)
    out = pred.to_dict()
    assert list(out) == [
        "gamma",
        "gamma_work",
        "lateral_work",
        "kappa",
        "wear_mm_per_1000km",
        "depth_now_mm",
        "km_to_3mm",
        "km_to_1_6mm",
        "depth_curve",
        "g_per_1000km_car_set",
        "wear_over_reference",
        "tyre_changes",
        "n_drives",
        "history_km",
    ]
    assert out["km_to_1_6mm"]["mean"] == 30000.0 and not out["km_to_1_6mm"]["already_below"]
    # a limit already passed reads 0 km to go, and says so
    assert out["km_to_3mm"]["mean"] == 0.0 and out["km_to_3mm"]["already_below"]
    rate = out["wear_mm_per_1000km"]["rear"]["mean"]
    assert rate == pytest.approx(1000.0 * pred.wear_mm_per_km[:, 1].mean())
    assert out["lateral_work"]["share_of_work"] == {"front": 0.3, "rear": 0.8}
    assert set(out["lateral_work"]["scale"]) == {"front", "rear"}
    assert out["tyre_changes"] == [
        {"drive_index": 3, "odometer_km": 4200.0, "change_type": "rotation", "probability": 0.9}
    ]
    np.testing.assert_array_equal(pred.wear_over_reference, pred.g_per_1000km_car_set / 100.0)
    assert out["wear_over_reference"]["reference_g_per_1000km"] == 100.0


def test_a_baseline_fit_has_no_kappa_and_no_lateral_scale():
    out = _prediction(
        np.full((len(LIMITS_MM), 50), 1e4), kappa_per_k=None, lateral_work_scale=None
    ).to_dict()
    assert "kappa" not in out and "scale" not in out["lateral_work"]


def test_one_row_of_distances_per_limit():
    with pytest.raises(ValueError, match="km_to_limit_km: expected 2 rows"):
        _prediction(np.full((1, 50), 1e4))
