"""tyrebayes.inference: NumPyro models and fitters, ArviZ output."""

from .tyre_data import TyreObservations as TyreObservations
from .tyre_data import observations_from_features as observations_from_features
from .tyre_data import observations_from_stream as observations_from_stream
from .tyre_data import stack_drives as stack_drives
from .tyre_data import windowed_observations as windowed_observations
from .tyre_fit import FitDiagnostics as FitDiagnostics
from .tyre_fit import TyreFit as TyreFit
from .tyre_fit import fit_tyre as fit_tyre
from .tyre_fit import fit_tyre_fast as fit_tyre_fast
from .tyre_fit import fit_tyre_nuts as fit_tyre_nuts
from .tyre_model import TyrePriors as TyrePriors
from .tyre_model import WindowLikelihood as WindowLikelihood
from .tyre_model import tyre_model as tyre_model
from .tyre_model import window_likelihood as window_likelihood
