"""Model criticism: find the effect the model does not know, extend the model, measure the gain.

Three tools, used by ``tyrebayes criticize`` and ``tyrebayes criticize-stream``:

* :func:`posterior_predictive_check` — test statistics of the data against their posterior
  predictive distribution, with posterior predictive p-values.
* :func:`criticize_table` — a fleet table (DESIGN.md contract) against the type-pooled regression
  of the outcome on 1/C_xr: every other column is a candidate covariate; each is scanned against
  the baseline's misfit (exact partial-F / likelihood-ratio test, Holm over candidates), then
  confirmed by an extended model compared with the baseline by PSIS-LOO (ELPD gain > 2 SE, Pareto
  k checked; units with k > 0.7 get the exact leave-one-out density). Each candidate comes with the
  posterior of its effect in natural units.
* :func:`criticize_stream` — the same for a sensor stream: the baseline linear-slip model
  rho_x = C_x (sigma_x - s0) pooled over the drive, scanned per segment (leave-one-segment-out).

The baselines are exact conjugate (Normal-Inverse-Gamma) Bayesian linear models: independent exact
posterior draws, closed-form leave-one-out as a check — see
:mod:`tyrebayes.criticism.linear`.

Modules: :mod:`.ppc` (posterior predictive checks), :mod:`.table` (fleet tables), :mod:`.stream`
(sensor streams), :mod:`.scan` (scan, confirmation, multiple testing), :mod:`.linear` (the
conjugate linear models and PSIS-LOO), :mod:`.fleet` (the fleet table's designs).
"""

from .ppc import DEFAULT_STATISTICS as DEFAULT_STATISTICS
from .ppc import posterior_predictive_check as posterior_predictive_check
from .scan import DEFAULT_ALPHA as DEFAULT_ALPHA
from .scan import ELPD_SE_FACTOR as ELPD_SE_FACTOR
from .scan import CandidateResult as CandidateResult
from .scan import CriticismResult as CriticismResult
from .stream import criticize_stream as criticize_stream
from .table import criticize_table as criticize_table
