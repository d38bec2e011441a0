"""Hierarchical fleet model: friction potential against inverse stiffness, pooled by tyre type.

The thesis (Sec. 6.1) fitted one least-squares line mu = b0 + b1 / C_xr through 26 winter tests.
This model keeps its physics (softer tyres grip better on snow) but knows what it does not know:
per surface and tyre type an intercept, a slope against 100 / C_xr and a residual scale, pooled
over types; each set's stiffness a latent variable observed with its standard error; priors per
type and surface from ``models/priors/tyre_types.toml`` (each number sourced there).

Modules: :mod:`.priors` (priors and their check against braking data), :mod:`.data` (the fleet
table), :mod:`.model` (the NumPyro model), :mod:`.fit` (:func:`fit_fleet`, NUTS or SVI, returning a
:class:`~tyrebayes.inference.result.Fit`), :mod:`.predict` (:func:`predict_friction`,
:func:`predictive_logpdf`, :func:`predictive_draws`, :func:`fit_summary`, and the per-type
lateral ratio c_y / C_xr: :func:`lateral_ratio_draws`, :func:`lateral_ratio_summary`).
"""

from .data import FleetData as FleetData
from .data import fleet_data_from_table as fleet_data_from_table
from .fit import fit_fleet as fit_fleet
from .model import X_SCALE as X_SCALE
from .model import fleet_model as fleet_model
from .predict import fit_summary as fit_summary
from .predict import has_lateral_ratio as has_lateral_ratio
from .predict import lateral_ratio_draws as lateral_ratio_draws
from .predict import lateral_ratio_summary as lateral_ratio_summary
from .predict import lateral_sets_per_type as lateral_sets_per_type
from .predict import predict_friction as predict_friction
from .predict import predictive_draws as predictive_draws
from .predict import predictive_logpdf as predictive_logpdf
from .predict import type_probabilities as type_probabilities
from .priors import ABS_EFFICIENCY_RANGE as ABS_EFFICIENCY_RANGE
from .priors import FleetPriors as FleetPriors
from .priors import load_tyre_type_priors as load_tyre_type_priors
from .priors import measured_braking_bounds as measured_braking_bounds
from .priors import prior_draws as prior_draws
from .priors import prior_predictive_check as prior_predictive_check
