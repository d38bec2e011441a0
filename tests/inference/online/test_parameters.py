"""θ's names and the type prior per tyre-curve model."""

import pytest

from tyrebayes.inference.online import parameter_names, type_prior


def test_the_type_prior_is_over_the_models_coordinates():
    prior = type_prior(model="brush")
    assert prior.model == "brush" and prior.names == parameter_names("brush")
    assert prior.mean.shape == (len(prior.names),)


@pytest.mark.parametrize("function", [parameter_names, type_prior])
def test_the_old_curve_keyword_is_refused_naming_model(function):
    with pytest.raises(TypeError, match="keyword 'kind' is now 'model'"):
        function(kind="brush")
