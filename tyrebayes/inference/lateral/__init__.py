"""Lateral tyre inference: per-axle cornering stiffness, understeer gradient and μ_y.

``data`` builds the cornering observations, ``model`` the NumPyro model, ``fit`` the fitter,
``result`` the :class:`LateralFit` it returns.
"""

from .data import CorneringObservations as CorneringObservations
from .data import NoCornering as NoCornering
from .data import cornering_observations as cornering_observations
from .fit import fit_lateral as fit_lateral
from .model import LateralPriors as LateralPriors
from .result import LateralFit as LateralFit
