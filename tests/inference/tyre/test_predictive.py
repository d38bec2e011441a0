"""The stored per-window groups of a tyre fit, and their recomputation from a compact fit file."""

import numpy as np
import pytest

from tyrebayes import BadInputError, load_fit
from tyrebayes.inference.tyre.data import stack_drives
from tyrebayes.inference.tyre.fit import fit_tyre
from tyrebayes.inference.tyre.predictive import (
    WINDOW_FIELDS,
    observations_from_fit,
    with_pointwise,
)

from .test_model import PAD, linear_region_windows


@pytest.fixture(scope="module")
def two_drive_fits(tmp_path_factory):
    """A drive fitted with and without the per-window groups (one ABS window, so at_limit is not
    all False), the compact one saved and read back. The shape of test_model's shared fit: no
    new compilation."""
    windows = linear_region_windows(4)
    windows = windows.replace(at_limit=np.arange(len(windows)) == 7)
    obs = stack_drives([windows], ["dry"], pad_to=PAD)
    full = fit_tyre(obs, method="fast", seed=2).fit
    compact = fit_tyre(obs, method="fast", seed=2, pointwise=False)
    path = compact.save(tmp_path_factory.mktemp("fits") / "compact.fit.nc")
    return obs, full, load_fit(path, kind="tyre")


def test_compact_fit_leaves_out_only_the_per_window_groups(two_drive_fits):
    _, full, compact = two_drive_fits
    assert {"log_likelihood", "posterior_predictive"} <= set(full.data.children)
    assert not {"log_likelihood", "posterior_predictive"} & set(compact.data.children)
    for name in ("c_xr", "mu_max", "slip_offset"):
        np.testing.assert_array_equal(compact.draws(name), full.draws(name))
    assert set(WINDOW_FIELDS) <= set(compact.data["constant_data"].data_vars)


def test_observations_are_rebuilt_from_the_file(two_drive_fits):
    obs, _, compact = two_drive_fits
    rebuilt = observations_from_fit(compact)
    used = np.asarray(obs.mask)
    assert rebuilt.n_drives == 1 and rebuilt.surfaces == obs.surfaces
    assert int(np.asarray(rebuilt.mask).sum()) == int(used.sum())
    n = int(used.sum())
    for name in ("slip", "rho", *WINDOW_FIELDS):
        np.testing.assert_array_equal(
            np.asarray(getattr(rebuilt, name))[:n], np.asarray(getattr(obs, name))[used]
        )


def test_recomputed_groups_equal_the_stored_ones(two_drive_fits):
    _, full, compact = two_drive_fits
    recomputed = with_pointwise(compact)
    for group in ("log_likelihood", "posterior_predictive"):
        for name in ("slip_obs", "rho_obs"):
            np.testing.assert_array_equal(
                np.asarray(recomputed.data[group][name]), np.asarray(full.data[group][name])
            )
    assert with_pointwise(full) is full


def test_a_file_without_the_windows_inputs_is_refused(two_drive_fits):
    _, _, compact = two_drive_fits
    data = compact.data.copy()
    data["constant_data"] = data["constant_data"].to_dataset().drop_vars("rho_score")
    old = type(compact)(
        data=data, diagnostics=compact.diagnostics, kind="tyre", provenance=compact.provenance
    )
    with pytest.raises(BadInputError, match="missing 'rho_score'"):
        with_pointwise(old)


def test_a_fit_without_load_sensitivity_needs_no_load_change(two_drive_fits):
    """A file written before the windows carried the load change still rebuilds (its model
    never read it); one whose model has q would not."""
    obs, _, compact = two_drive_fits
    data = compact.data.copy()
    data["constant_data"] = data["constant_data"].to_dataset().drop_vars("load_change")
    old = type(compact)(
        data=data, diagnostics=compact.diagnostics, kind="tyre", provenance=compact.provenance
    )
    rebuilt = observations_from_fit(old)
    assert not np.any(np.asarray(rebuilt.load_change))
    assert int(np.asarray(rebuilt.mask).sum()) == obs.n_used


def test_a_compact_fit_is_criticised_as_the_full_one(two_drive_fits):
    from tyrebayes.criticism import criticize_tyre_fit

    _, full, compact = two_drive_fits
    settings = {"n_draws": 50, "n_permutations": 20, "seed": 0}
    a, b = criticize_tyre_fit(full, **settings), criticize_tyre_fit(compact, **settings)
    assert a.baseline.elpd == b.baseline.elpd
    assert a.ppc == b.ppc
    assert [(c.covariate, c.p_value) for c in a.candidates] == [
        (c.covariate, c.p_value) for c in b.candidates
    ]
