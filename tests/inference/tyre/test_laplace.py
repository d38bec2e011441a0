"""The Laplace core's model layout does not depend on the number of windows it is traced on."""

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
