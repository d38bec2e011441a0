"""Abrasability gamma from tread-depth readings and/or rolling-radius drift (NumPyro).

Model (per tyre set *s* of type *t*, drive *d*, axle *a*, temperature bin *b*)::

    mu_t            ~ Normal(log gamma_median, gamma_log_sd)          type-level log abrasability
    tau             ~ HalfNormal(type_spread)                          spread of sets within a type
    log gamma_s     ~ Normal(mu_t, tau)                                (pooled by type)
    C_xr,s          ~ LogNormal(from the per-tyre posterior: draws or mean/sd)   marginalised
    kappa_t         ~ Normal(0, kappa_sd)      [extended model only; baseline kappa = 0]
    V_s,d,a         = gamma_s sum_b K_s,d,a,b exp(kappa_t (T_b - 20)) / C_x(C_xr,s, T_b)
                      (thesis eq. 4.26 with slip 4.27; K = binned rho^2 F_z V dt from the drive)
    loss_s,d,a      = cumsum_d V / A_wear                              depth lost [mm]
    depth_j         ~ Normal(d0_s,a - loss_s,d(j),a(j), sigma_depth)   tread-depth readings
    drift_s,d       ~ Normal(offset_s - lambda (loss_f - loss_r) / R_0, sigma_radius)

The friction work comes from each drive's own data (speed, force, load, ambient -> tyre
temperature through :mod:`tyrebayes.physics.thermal`), so the uncertainty of C_xr flows into gamma:
wear constrains gamma / C_xr, the stiffness posterior splits it.

Modules: :mod:`.data` (priors, :class:`WearSet`, :class:`WearData`, :func:`build_wear_data`),
:mod:`.model` (:func:`wear_model`), :mod:`.fit` (:func:`fit_wear`: NUTS or MAP + Laplace, a
:class:`~tyrebayes.inference.result.Fit` of kind "wear"), :mod:`.predict`
(:func:`predict_wear_volume`, :func:`relative_wear_draws`). The warning rule on relative wear is
a decision: :func:`tyrebayes.decisions.high_wear_warning`.

One car's own drive history (``tyrebayes fit-wear``): :mod:`.history` (:func:`drive_history`,
:func:`tread_readings`), :mod:`.changepoint` (:func:`detect_tyre_changes`),
:mod:`.change_readings` (the readings' say in a change's type), :mod:`.history_fit`
(:func:`fit_wear_history`, a Fit of kind "wear_history") and :mod:`.history_predict`
(:func:`wear_history_predictions`, a :class:`WearHistoryPrediction`); :mod:`.cornering`
(:func:`cornering_stiffness_from_lateral`: the per-axle c_y behind the evidence's lateral work,
from a lateral posterior; :func:`cornering_stiffness_from_drives`: from a history's own drives).
"""

from .changepoint import TyreChanges as TyreChanges
from .changepoint import detect_tyre_changes as detect_tyre_changes
from .cornering import DrivesCornering as DrivesCornering
from .cornering import cornering_stiffness_from_draws as cornering_stiffness_from_draws
from .cornering import cornering_stiffness_from_drives as cornering_stiffness_from_drives
from .cornering import cornering_stiffness_from_lateral as cornering_stiffness_from_lateral
from .data import WearData as WearData
from .data import WearPriors as WearPriors
from .data import WearSet as WearSet
from .data import build_wear_data as build_wear_data
from .data import c_xr_lognormal as c_xr_lognormal
from .fit import WEAR_METHODS as WEAR_METHODS
from .fit import fit_wear as fit_wear
from .fit import wear_fit_parts as wear_fit_parts
from .history import DriveHistory as DriveHistory
from .history import TreadReadings as TreadReadings
from .history import drive_history as drive_history
from .history import tread_readings as tread_readings
from .history_fit import fit_wear_history as fit_wear_history
from .history_predict import WearHistoryPrediction as WearHistoryPrediction
from .history_predict import wear_history_predictions as wear_history_predictions
from .model import init_values as init_values
from .model import wear_factor as wear_factor
from .model import wear_model as wear_model
from .predict import gamma_summary as gamma_summary
from .predict import predict_wear_volume as predict_wear_volume
from .predict import relative_wear_draws as relative_wear_draws
