"""The online estimator's settings: the default drifts per tyre-curve model."""

import pytest

from tyrebayes.inference.online import default_config, parameter_names


@pytest.mark.parametrize("model", ["magic", "linear"])
def test_default_config_has_a_drift_per_coordinate_of_the_model(model):
    config = default_config(model)
    assert config.drift_sd_per_sqrt_s.shape == (len(parameter_names(model)),)


def test_default_config_refuses_the_old_curve_keyword_naming_model():
    with pytest.raises(TypeError, match="default_config: keyword 'kind' is now 'model'"):
        default_config(kind="magic")
