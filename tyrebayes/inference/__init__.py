"""tyrebayes.inference: NumPyro models and fitters; every fit is a :class:`Fit` (``result``).

:mod:`.result` holds the one result type, its diagnostics and the one policy; :mod:`.fleet` and
:mod:`.wear` are packages (priors/data, model, fit, predict); the per-tyre model lives in the
``tyre_*`` modules.
"""

from .result import POLICY as POLICY
from .result import ConvergencePolicy as ConvergencePolicy
from .result import Diagnostics as Diagnostics
from .result import Fit as Fit
from .result import Provenance as Provenance
from .result import diagnose as diagnose
from .result import load_fit as load_fit
from .tyre_data import TyreObservations as TyreObservations
from .tyre_data import observations_from_features as observations_from_features
from .tyre_data import observations_from_stream as observations_from_stream
from .tyre_data import stack_drives as stack_drives
from .tyre_data import windowed_observations as windowed_observations
from .tyre_fit import TyreFit as TyreFit
from .tyre_fit import fit_tyre as fit_tyre
from .tyre_fit import fit_tyre_fast as fit_tyre_fast
from .tyre_fit import fit_tyre_nuts as fit_tyre_nuts
from .tyre_model import TyrePriors as TyrePriors
from .tyre_model import WindowLikelihood as WindowLikelihood
from .tyre_model import tyre_model as tyre_model
from .tyre_model import window_likelihood as window_likelihood
