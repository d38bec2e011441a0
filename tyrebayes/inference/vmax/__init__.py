"""Predictive V_max of the ISO 3888-2 lane change, and the measured Table 6.2 as censored data.

Type-level relations (assumptions, stated because no cornering data exist for the thesis sets):

* lateral stiffness: C_y = k_type · C_xr [1/rad], k ~ LogNormal(log k_type, 0.15) with k_type =
  0.45 (winter), 0.40 (all-season), 0.35 (summer): softer winter treads lose less cornering
  stiffness per unit of longitudinal stiffness (block bending shares both);
* lateral friction on dry asphalt at 5-10 °C: μ_y = 0.95 · μ_x, μ_x ~ Normal(μ_type, 0.05) with
  μ_type = 0.95 (winter), 1.00 (all-season), 1.05 (summer).

Measured lateral parameters replace both relations where a fit carries a lateral posterior
(:func:`fit_vmax_inputs`): the per-axle c_y front and rear [1/rad over the static axle load]
enter the simulation as they are (:class:`~tyrebayes.physics.lanechange.AxleTyres`; C_f =
c_y_front · m g l_r / L N/rad), and μ_y is the lateral fit's where the drive neared the peak,
else the longitudinal μ_max where that fit observed it, else the lateral posterior's (the
surface's prior, bounded below by the forces the drive used). Each prediction says which
(:class:`VmaxInputs`: ``lateral_source`` "measured" / "fleet_type_ratio" / "type_prior",
``mu_y_source`` "measured" / "mu_max" / "surface_prior" / "type_prior"). A measured μ_y belongs to
the drive's surface; the type relations describe dry asphalt.

A set measured only in straight driving, in a fleet whose fit learnt the per-type ratio
k = c_y / C_xr (:func:`tyrebayes.inference.fleet.lateral_ratio_draws`), takes C_y = k · C_xr with
k drawn from its type's posterior predictive (``lateral_source`` "fleet_type_ratio",
:func:`fleet_ratio_vmax_inputs`) in place of the fixed k_type; μ_y stays the type relation's.

Measurements (thesis Table 6.2): the driver raised the speed in steps of 10 km/h until a cone fell,
so the recorded V_max means V ∈ [v_pass, v_pass + 10) km/h (interval censoring).

Models for the six measured sets:

* **driver-free**: V_i ~ Normal(m_i, s_i² + σ_rep²), (m_i, s_i) the simulation's predictive mean and
  sd, σ_rep = 2 km/h run-to-run repeatability, no free parameters;
* **extended**: V_i ~ Normal(m_i + δ − a (m_i − m̄), s_i² + σ_d²) with a driver offset
  δ ~ Normal(0, 20) km/h (a skilled driver beats the simple preview driver), an adaptation
  a ~ Normal(0, 1) (the fraction of the predicted tyre effect the driver compensates) and driver
  noise σ_d ~ HalfNormal(10) km/h, in NumPyro.

Modules: :mod:`.inputs` (:class:`VmaxInputs`, the sources), :mod:`.type_relations`
(:func:`type_vmax_inputs`), :mod:`.fleet_ratio` (:func:`fleet_ratio_vmax_inputs`),
:mod:`.lateral` (:func:`lateral_vmax_inputs`, :func:`surface_mu_y_draws`),
:mod:`.fit_inputs` (:func:`fit_vmax_inputs`: the three in their order), :mod:`.prediction`
(:func:`vmax_draws`, :func:`predict_vmax`, :class:`VmaxPrediction`) and :mod:`.censored` (the
measured Table 6.2 and its models).
"""

from .censored import REPEATABILITY_KMH as REPEATABILITY_KMH
from .censored import SPEED_STEP_KMH as SPEED_STEP_KMH
from .censored import censored_loglik as censored_loglik
from .censored import extended_model as extended_model
from .censored import fit_extended as fit_extended
from .censored import load_table_6_2 as load_table_6_2
from .censored import pointwise_log_lik as pointwise_log_lik
from .censored import power_table as power_table
from .censored import psis_loo as psis_loo
from .fit_inputs import fit_vmax_inputs as fit_vmax_inputs
from .fleet_ratio import fleet_ratio_vmax_inputs as fleet_ratio_vmax_inputs
from .inputs import LATERAL_SOURCES as LATERAL_SOURCES
from .inputs import MU_Y_SOURCES as MU_Y_SOURCES
from .inputs import TYPE_SURFACE as TYPE_SURFACE
from .inputs import VmaxInputs as VmaxInputs
from .lateral import lateral_vmax_inputs as lateral_vmax_inputs
from .lateral import surface_mu_y_draws as surface_mu_y_draws
from .prediction import SEARCH_RANGE_KMH as SEARCH_RANGE_KMH
from .prediction import VmaxPrediction as VmaxPrediction
from .prediction import predict_vmax as predict_vmax
from .prediction import range_counts as range_counts
from .prediction import vmax_draws as vmax_draws
from .type_relations import K_TYPE as K_TYPE
from .type_relations import MU_TYPE as MU_TYPE
from .type_relations import MU_Y_RATIO as MU_Y_RATIO
from .type_relations import lateral_draws as lateral_draws
from .type_relations import type_vmax_inputs as type_vmax_inputs
