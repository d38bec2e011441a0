"""The result of a lateral fit: :class:`LateralFit`, wrapping the one result type (``Fit``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..result import Fit
from ..summary import summarize


@dataclasses.dataclass(frozen=True)
class LateralFit:
    """Result of :func:`~tyrebayes.inference.lateral.fit.fit_lateral`: a ``Fit`` of kind "lateral".

    Attributes
    ----------
    fit : Fit
        Posterior of ``c_y_front``, ``c_y_rear`` [1/rad], ``understeer_gradient`` [rad/(m/s²)],
        ``mu_y``, ``steering_ratio`` and the nuisances; diagnostics and provenance.
    mu_y_observed : bool
        Whether the drive neared the peak: an axle used at least
        :data:`~.fit.MU_Y_USE_OBSERVED` of the posterior μ_y and the data narrowed μ_y's
        log-sd to half the prior's or less. Otherwise μ_y is the prior's and not reported.
    identified : bool
        Whether the data determined the understeer gradient (its posterior sd at most half the
        prior's). A kinematic (low-speed) drive is not identified.
    cornering_seconds : float
        Time the drive spent cornering (|a_y| > 1 m/s² above 8 m/s) [s].
    peak_use : float
        The 99th percentile of the axles' |ρ_y| over the posterior mean μ_y [-].
    road_wheel : bool
        The log gave the road-wheel angle (no steering ratio inferred).
    """

    fit: Fit
    mu_y_observed: bool
    identified: bool
    cornering_seconds: float
    peak_use: float
    road_wheel: bool

    @property
    def converged(self) -> bool:
        return self.fit.converged

    @property
    def adequate(self) -> bool:
        return self.fit.adequate

    def unusable_reason(self) -> str:
        """Why the stiffnesses are not to be used downstream (V_max, the wear's lateral work, a
        fleet's c_y), in one line; "" when they are: a fit that did not converge, or one whose
        model does not describe its drive (its adequacy reasons)."""
        diagnostics = self.fit.diagnostics
        if not self.converged:
            return "the lateral fit did not converge: " + "; ".join(diagnostics.reasons)
        if not self.adequate:
            return "the lateral fit does not describe the drive: " + "; ".join(
                diagnostics.adequacy_reasons
            )
        return ""

    def draws(self, name: str) -> np.ndarray:
        return self.fit.draws(name)

    def curve_shape(self, axle: str) -> tuple[np.ndarray, np.ndarray]:
        """Draws of ``axle``'s Magic Formula shape C and curvature E ("front" or "rear").

        A fit without the ``axle_shapes`` effect holds the front's, which serves both axles; a
        fit file whose model gave both axles one curve holds ``curve_shape_excess`` and
        ``curve_curvature_gap`` without an axle.
        """
        if axle not in ("front", "rear"):
            raise ValueError(f"axle: expected 'front' or 'rear', got {axle!r}")
        post = self.fit.posterior
        suffix = next((s for s in (f"_{axle}", "_front") if f"curve_shape_excess{s}" in post), "")
        return (
            1.0 + self.draws(f"curve_shape_excess{suffix}"),
            1.0 - self.draws(f"curve_curvature_gap{suffix}"),
        )

    def to_dict(self) -> dict:
        """The ``"lateral"`` object of ``fit-tyre --json`` (``{"mean", "sd", "hdi_90"}`` each).

        ``steering_ratio`` is null where the log gave the road-wheel angle; ``mu_y`` is null
        unless ``mu_y_observed``.
        """
        post = self.fit.posterior
        return {
            "c_y_front": summarize(self.draws("c_y_front")).to_dict(),
            "c_y_rear": summarize(self.draws("c_y_rear")).to_dict(),
            "understeer_gradient": summarize(self.draws("understeer_gradient")).to_dict(),
            "steering_ratio": (
                summarize(self.draws("steering_ratio")).to_dict()
                if "steering_ratio" in post
                else None
            ),
            "mu_y": summarize(self.draws("mu_y")).to_dict() if self.mu_y_observed else None,
            "mu_y_observed": bool(self.mu_y_observed),
            "identified": bool(self.identified),
            "converged": bool(self.converged),
            "adequate": bool(self.adequate),
            "adequacy_reasons": list(self.fit.diagnostics.adequacy_reasons),
            **{
                name: summarize(self.draws(name)).to_dict()
                for name in (
                    "roll_gradient",
                    "steering_offset",
                    "ay_offset",
                    "yaw_inertia_factor",
                    "relaxation_length",
                )
                if name in post
            },
            "front_rear_correlation": float(
                np.corrcoef(np.log(self.draws("c_y_front")), np.log(self.draws("c_y_rear")))[0, 1]
            ),
            "cornering_seconds": float(self.cornering_seconds),
            "peak_use": float(self.peak_use),
            "method": self.fit.diagnostics.method,
        }

    def attrs(self) -> dict:
        """The fields beside the posterior, as the saved file's attributes."""
        return {
            "lateral_mu_y_observed": int(self.mu_y_observed),
            "lateral_identified": int(self.identified),
            "lateral_cornering_seconds": float(self.cornering_seconds),
            "lateral_peak_use": float(self.peak_use),
            "lateral_road_wheel": int(self.road_wheel),
        }

    @classmethod
    def from_fit(cls, fit: Fit) -> LateralFit:
        """The lateral fit a ``Fit`` of kind "lateral" holds (a loaded file's)."""
        if fit.kind != "lateral":
            raise ValueError(f"fit: expected a lateral fit, got a {fit.kind} fit")
        a = fit.data.attrs
        return cls(
            fit=fit,
            mu_y_observed=bool(int(a["lateral_mu_y_observed"])),
            identified=bool(int(a["lateral_identified"])),
            cornering_seconds=float(a["lateral_cornering_seconds"]),
            peak_use=float(a["lateral_peak_use"]),
            road_wheel=bool(int(a["lateral_road_wheel"])),
        )

    def __repr__(self) -> str:
        d = self.to_dict()
        return (
            f"LateralFit(c_y_front={d['c_y_front']['mean']:.3g}, "
            f"c_y_rear={d['c_y_rear']['mean']:.3g}, "
            f"K={d['understeer_gradient']['mean']:.3g}, converged={d['converged']})"
        )
