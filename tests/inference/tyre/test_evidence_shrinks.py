"""Less evidence never narrows the posterior: half the windows, or half the samples dropped,
give a C_x at least as wide as the whole log's (issue: no silent wrong answers)."""

import numpy as np
import pytest

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.tyre.data import observations_from_features, stack_drives
from tyrebayes.inference.tyre.fit import fit_tyre
from tyrebayes.simulate.drive import simulate_drive
from tyrebayes.streams import compute_features, validate_stream

PAD = 1024


@pytest.fixture(scope="module")
def drive():
    vehicle = load_vehicle("compact_fwd")
    df, _ = simulate_drive(5, vehicle, "all_season", duration_s=240.0)
    return vehicle, df


def _c_x_sd(vehicle, df, keep_every: int = 1) -> float:
    features = compute_features(validate_stream(df, vehicle), vehicle)
    windows = observations_from_features(features)
    windows = windows.select(slice(None, None, keep_every))
    fit = fit_tyre(stack_drives([windows], ["dry"], pad_to=PAD), method="fast", seed=0)
    assert fit.diagnostics.converged, fit.diagnostics.reason
    return float(np.std(fit.draws("c_x")))


def test_half_the_windows_or_half_the_samples_never_narrow_c_x(drive):
    vehicle, df = drive
    full = _c_x_sd(vehicle, df)
    assert _c_x_sd(vehicle, df, keep_every=2) >= full
    # Every other sample dropped (NaN): each window averages half as many samples.
    holes = df.copy()
    channels = [c for c in holes.columns if c != "time"]
    holes.loc[holes.index[1::2], channels] = np.nan
    # 1 %: the two fits share their Laplace draws' random numbers, not their Hessians.
    assert _c_x_sd(vehicle, holes) >= 0.99 * full
