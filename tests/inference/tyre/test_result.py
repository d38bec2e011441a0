"""A tyre fit's file: the curve model is stored as the ``tyre_model`` attribute and read back."""

import json

import arviz_base as azb
import numpy as np

from tyrebayes.inference.diagnostics import diagnose
from tyrebayes.inference.result import Fit, load_fit, provenance
from tyrebayes.inference.tyre.adequacy import Adequacy
from tyrebayes.inference.tyre.result import TyreFit


def _posterior():
    rng = np.random.default_rng(2)
    post = {
        "c_xr": 35.0 + rng.normal(size=(1, 50)),
        "mu_max": 1.0 + 0.01 * rng.normal(size=(1, 50, 1)),
    }
    return azb.from_dict({"posterior": post}, dims={"mu_max": ["surface"]})


def test_a_file_written_by_hand_with_the_old_attributes_loads_with_its_model(tmp_path):
    # The attributes exactly as fit files carried them before ``TyreFit.kind`` became ``model``.
    data = _posterior()
    data.attrs.update(
        {
            "mu_observed": json.dumps({"dry": False}),
            "surfaces": json.dumps(["dry"]),
            "n_samples_used": 100,
            "tyre_model": "brush",
            "slip_variance_inflation": json.dumps([1.0]),
            "adequacy": json.dumps(Adequacy(True, (), 1.0, 0.1, 0.0, 0.0).as_dict()),
            "force_range": 0.2,
            "secant_stiffness": json.dumps([30.0, 31.0]),
            "lateral_reason": "",
        }
    )
    fit = Fit(
        data=data,
        diagnostics=diagnose(data, method="fast", optimiser_result="successful"),
        kind="tyre",
        provenance=provenance("fast", "brush", ("drive.csv",)),
    )
    loaded = TyreFit.from_fit(load_fit(fit.save(tmp_path / "old.nc"), kind="tyre"))
    assert loaded.model == "brush" and loaded.surfaces == ("dry",)
    assert loaded.fit.data.attrs["tyre_model"] == "brush"
