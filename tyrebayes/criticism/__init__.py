"""Model criticism: find the effect the model does not know, with stated error rates.

Tools, used by ``tyrebayes criticize`` and ``tyrebayes criticize-stream``:

* :func:`criticize_fleet_fit` — a fitted hierarchical fleet model (fit file) against its fleet
  table: posterior predictive checks from the fit, and its residuals scanned against every other
  column.
* :func:`criticize_tyre_fit` — a fitted per-tyre model (fit file): posterior predictive checks of
  the slip, and the slip residuals scanned against the drive's conditions (force level, tyre
  temperature, time in drive, drive, surface).
* :func:`criticize_table` — a fleet table against an exact conjugate type-pooled regression of the
  outcome on 1/C_xr (fast; C_xr taken as exact).
* :func:`criticize_stream` — a sensor stream against the linear-slip model rho_x = C_x (sigma_x -
  s0), scanned per segment.
* :func:`posterior_predictive_check` — test statistics of the data against their posterior
  predictive distribution.

All of them decide with one rule (:mod:`.scan`): a permutation p-value per candidate
(:mod:`.permutation`), Benjamini-Hochberg over candidates at a false-discovery rate ``alpha``
(default 5 %), and a positive PSIS-LOO ELPD gain of the extended model — a finding with a negative
gain cannot happen. Each candidate is reported with its effect (posterior mean, 90 % HDI), p- and
q-value, ELPD gain and SE.

Modules: :mod:`.ppc`, :mod:`.permutation`, :mod:`.scan`, :mod:`.linear` (conjugate linear models
and PSIS-LOO), :mod:`.fleet` (the fleet table's designs), :mod:`.table`, :mod:`.fleet_fit`,
:mod:`.tyre_fit`, :mod:`.stream`.
"""

from .fleet_fit import criticize_fleet_fit as criticize_fleet_fit
from .permutation import DEFAULT_PERMUTATIONS as DEFAULT_PERMUTATIONS
from .ppc import DEFAULT_STATISTICS as DEFAULT_STATISTICS
from .ppc import PredictiveChecks as PredictiveChecks
from .ppc import StatisticCheck as StatisticCheck
from .ppc import posterior_predictive_check as posterior_predictive_check
from .scan import DEFAULT_ALPHA as DEFAULT_ALPHA
from .scan import ELPD_SE_FACTOR as ELPD_SE_FACTOR
from .scan import CandidateResult as CandidateResult
from .scan import CriticismResult as CriticismResult
from .stream import criticize_stream as criticize_stream
from .table import criticize_table as criticize_table
from .tyre_fit import criticize_tyre_fit as criticize_tyre_fit
