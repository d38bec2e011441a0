"""The Laplace core's model layout: independent of the number of windows it is traced on."""

from __future__ import annotations

import jax
import numpy as np
from numpyro.infer import init_to_median
from numpyro.infer.util import initialize_model

from tyrebayes.inference.tyre.laplace import (
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

    from tyrebayes.inference.tyre.laplace import _site_plates
    from tyrebayes.inference.tyre.model import tyre_model

    model = partial(tyre_model, priors=TyrePriors(), kind="brush")
    plates = _site_plates(model, _template_observations(LAYOUT_WINDOWS, 3, ("dry",)))
    assert plates["c_xr"] == ()
    assert "drive" in plates["slip_offset"] and "drive" in plates["force_gain"]
    assert "surface" in plates["mu_max"] and "drive" not in plates["mu_max"]
