"""The in-car estimator: the per-tyre posterior updated online, window block by window block.

:mod:`.estimator` holds :class:`OnlineEstimator` (``init``, ``update``, ``summary``, ``run``),
:mod:`.driver` its compiled runs over streams;
the parts are one concept per module: θ and the type prior (:mod:`.parameters`), the blocks of
windows it reads (:mod:`.windows`), their likelihood (:mod:`.block_likelihood`), the Laplace
update (:mod:`.laplace_update`), how θ moves between steps (:mod:`.process`), the change
detector (:mod:`.change`), the slip errors' inflation (:mod:`.inflation`), the state
(:mod:`.state`), settings (:mod:`.config`), the reported estimate and its readiness
(:mod:`.summary`), a stream's run (:mod:`.run`) and the linear-model EKF it is compared with
(:mod:`.linear_ekf`). Beside it the lateral estimator: c_y front and rear and the understeer
gradient (:mod:`.lateral`), its blocks (:mod:`.lateral_blocks`), the batch model's priors
(:mod:`.lateral_prior`), a block's sufficient statistics (:mod:`.lateral_statistics`), the
residuals' VIF (:mod:`.lateral_vif`), its state (:mod:`.lateral_state`), its estimate
(:mod:`.lateral_summary`) and a drive's run (:mod:`.lateral_run`).
"""

from .config import OnlineConfig as OnlineConfig
from .config import default_config as default_config
from .driver import COMPILER_OPTIONS as COMPILER_OPTIONS
from .driver import online_estimate as online_estimate
from .driver import run_online as run_online
from .driver import run_online_cars as run_online_cars
from .estimator import OnlineEstimator as OnlineEstimator
from .lateral import OnlineLateralEstimator as OnlineLateralEstimator
from .lateral import online_lateral as online_lateral
from .lateral_blocks import LateralBlocks as LateralBlocks
from .lateral_blocks import lateral_blocks as lateral_blocks
from .lateral_run import LateralRun as LateralRun
from .lateral_summary import LateralTrajectory as LateralTrajectory
from .lateral_summary import OnlineLateral as OnlineLateral
from .linear_ekf import LinearEkfTrajectory as LinearEkfTrajectory
from .linear_ekf import linear_ekf as linear_ekf
from .parameters import GaussianPrior as GaussianPrior
from .parameters import parameter_names as parameter_names
from .parameters import type_prior as type_prior
from .run import OnlineRun as OnlineRun
from .state import FilterState as FilterState
from .stream import stream_steps as stream_steps
from .stream import stream_windows as stream_windows
from .summary import OnlineSummary as OnlineSummary
from .windows import PACKED_STEP_S as PACKED_STEP_S
from .windows import STEP_S as STEP_S
from .windows import WindowBlocks as WindowBlocks
from .windows import pad_steps as pad_steps
from .windows import window_blocks as window_blocks
