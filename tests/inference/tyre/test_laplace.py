"""The Laplace core's model layout: independent of the number of windows it is traced on."""

from __future__ import annotations

import jax
import numpy as np
from numpyro.infer import init_to_median
from numpyro.infer.util import initialize_model

from tyrebayes.inference.tyre.layout import (
    LAYOUT_WINDOWS,
    _model_layout,
    _template_observations,
)
from tyrebayes.inference.tyre.model import TyrePriors
from tyrebayes.inference.tyre.predictive import _priors_key


def test_layout_is_the_same_as_on_a_template_of_the_data_length():
    key = _priors_key(TyrePriors())
    surfaces = ("dry", "snow")
    model, template, params = _model_layout(key, "brush", (4096, 2, surfaces))
    assert template.slip.shape == (LAYOUT_WINDOWS,)
    # What the layout was before: initialised on a template of the data's own length.
    with jax.numpy_rank_promotion("allow"):
        full = initialize_model(
            jax.random.PRNGKey(0),
            model,
            model_args=(_template_observations(4096, 2, surfaces),),
            init_strategy=init_to_median,
        ).param_info.z
    assert sorted(params) == sorted(full)
    for name in full:
        np.testing.assert_array_equal(np.asarray(params[name]), np.asarray(full[name]))
    # Cached per drives and surfaces: another padded length reuses it.
    assert _model_layout(key, "brush", (8192, 2, surfaces))[2] is params


def test_site_plates_name_the_drive_plate_of_per_drive_sites():
    from functools import partial

    from tyrebayes.inference.tyre.block_hessian import _site_plates
    from tyrebayes.inference.tyre.model import tyre_model

    model = partial(tyre_model, priors=TyrePriors(), model="brush")
    plates = _site_plates(model, _template_observations(LAYOUT_WINDOWS, 3, ("dry",)))
    assert plates["c_xr"] == ()
    assert "drive" in plates["slip_offset"] and "drive" in plates["force_gain"]
    assert "surface" in plates["mu_max"] and "drive" not in plates["mu_max"]


def test_a_refit_from_the_first_mode_reaches_the_weighted_posteriors_searched_mode():
    # The fast fit's second pass (slip weights from the first pass's residuals) refits from
    # the first pass's mode instead of searching again: it must end where a search would.
    import dataclasses

    import jax.numpy as jnp

    from tyrebayes.inference.tyre.data import stack_drives
    from tyrebayes.inference.tyre.fit import LAPLACE_DRAWS
    from tyrebayes.inference.tyre.laplace import _laplace_core, optimiser_outcome
    from tyrebayes.inference.tyre.model import DEFAULT_MODEL
    from tyrebayes.inference.tyre.predictive import _obs_key

    from .test_model import PAD, linear_region_windows

    obs = stack_drives([linear_region_windows(3)], ["dry"], pad_to=PAD)
    # Same shape and settings as the fits of test_fit.py: no new compilation.
    core = _laplace_core(
        _priors_key(TyrePriors()), DEFAULT_MODEL, _obs_key(obs), LAPLACE_DRAWS, 2000
    )
    key, eye = jax.random.PRNGKey(0), jnp.eye(core.flat0.shape[0])
    first_mode, _, whiten, _ = core.mode(core.flat0, obs, eye, True)
    weighted = dataclasses.replace(obs, slip_weight=jnp.full_like(obs.slip, 0.4))
    searched = core.mode(core.flat0, weighted, eye, True)[0]
    refitted, code, _, _ = core.mode(first_mode, weighted, whiten, False)
    assert optimiser_outcome(code) == "successful"
    # The weights moved the mode (else the test shows nothing), and the refit followed.
    _, scale_searched, _ = core.laplace(searched, weighted, key)
    _, scale_refitted, _ = core.laplace(refitted, weighted, key)
    sd = jnp.sqrt(jnp.sum(scale_searched**2, axis=1))  # posterior sds of the flat parameters
    assert float(jnp.max(jnp.abs(searched - first_mode) / sd)) > 0.1
    np.testing.assert_array_less(jnp.abs(refitted - searched) / sd, 0.01)
    # The same Laplace covariance S S' (S itself is defined up to its eigenvectors' signs).
    cov_refitted, cov_searched = (s @ s.T for s in (scale_refitted, scale_searched))
    np.testing.assert_allclose(
        cov_refitted, cov_searched, rtol=1e-3, atol=1e-3 * float(sd.min()) ** 2
    )


def test_layout_medians_are_kept_beside_the_compilation_cache_and_read_back_equal(
    compilation_cache_dir,
):
    from tyrebayes.inference.tyre.layout import _layout, _read_medians, _stored_medians_path

    key = (_priors_key(TyrePriors()), "brush", 2, ("dry",))
    path = _stored_medians_path(key)
    assert path.parent.parent == compilation_cache_dir and not path.exists()
    computed = _layout.__wrapped__(*key)[2]  # no stored medians: computed, then kept
    assert path.exists()
    loaded = _layout.__wrapped__(*key)[2]
    assert sorted(loaded) == sorted(computed)
    for name in computed:
        np.testing.assert_array_equal(np.asarray(loaded[name]), np.asarray(computed[name]))
    # A file that is not what it claims is not read (the layout is then computed again).
    path.write_bytes(b"not an npz")
    assert _read_medians(path) is None
