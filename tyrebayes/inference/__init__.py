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
from .tyre.data import TyreObservations as TyreObservations
from .tyre.data import WindowTable as WindowTable
from .tyre.data import observations_from_features as observations_from_features
from .tyre.data import observations_from_stream as observations_from_stream
from .tyre.data import stack_drives as stack_drives
from .tyre.data import windowed_observations as windowed_observations
from .tyre.fit import TyreFit as TyreFit
from .tyre.fit import fit_tyre as fit_tyre
from .tyre.fit import fit_tyre_fast as fit_tyre_fast
from .tyre.fit import fit_tyre_nuts as fit_tyre_nuts
from .tyre.model import TyrePriors as TyrePriors
from .tyre.model import WindowLikelihood as WindowLikelihood
from .tyre.model import WindowQuantities as WindowQuantities
from .tyre.model import likelihood_of_quantities as likelihood_of_quantities
from .tyre.model import tyre_model as tyre_model
from .tyre.model import window_likelihood as window_likelihood
from .tyre.model import window_quantities as window_quantities
from .tyre.predictive import observations_from_fit as observations_from_fit
from .tyre.predictive import with_pointwise as with_pointwise
