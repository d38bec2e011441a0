"""The result of a per-tyre fit: :class:`TyreFit`, wrapping the one result type (``result.Fit``)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import xarray as xr

from ..lateral.result import LateralFit
from ..result import Diagnostics, Fit, Provenance, _finite_json
from ..summary import summarize
from .adequacy import Adequacy

#: The node of a tyre fit's data that holds its lateral fit (:class:`LateralFit`), if any.
LATERAL_NODE = "lateral"


@dataclasses.dataclass(frozen=True)
class TyreFit:
    """Result of :func:`fit_tyre`: a :class:`~tyrebayes.inference.result.Fit` of kind "tyre".

    Attributes
    ----------
    idata : xarray.DataTree
        ArviZ data: posterior (``c_xr``, ``c_x``, ``mu_max``, ``slip_offset``, ...), observed
        data, log-likelihood, posterior predictive, constant data (``at_limit``).
    diagnostics : Diagnostics
        Convergence under :data:`~tyrebayes.inference.result.POLICY` and model adequacy.
    mu_observed : dict[str, bool]
        Per surface: did the data reach the nonlinear region (posterior contraction of μ_max)?
    surfaces : tuple of str
    n_samples_used : int
        Number of windows that entered the likelihood.
    model : str
        The tyre-curve model: ``"magic"``, ``"shaped"``, ``"brush"`` or ``"linear"``.
    slip_variance_inflation : tuple of float
        Per drive, the variance inflation of the slip errors by their correlation between
        windows; each window's slip counted 1/this in the fit (:mod:`.window_correlation`).
    adequacy : Adequacy
        Whether the fitted model describes the drive (:mod:`.adequacy`), with the statistics of
        its checks; a converged fit can be inadequate, and then its intervals are not to be
        trusted either. ``diagnostics.adequate`` carries its verdict and reasons.
    force_range : float
        The 90th percentile of |ρ_x| over the slip windows [-]: the range of force the drive used.
    secant_stiffness : ndarray
        Posterior draws of the secant slope ρ/σ of the fitted curve at ``force_range`` [-], on
        the first surface at the drives' mean tyre temperature: what the drive measures directly.
        C_x, the slope at zero, is that secant extrapolated through the curve's shape.
    provenance : Provenance, optional
        Method, model, inputs and settings (default: method and model only).
    lateral : LateralFit or None
        The same drive's cornering fit (per-axle c_y, understeer gradient, μ_y), or None.
    lateral_reason : str
        Why there is no lateral fit (no usable cornering, not identified); "" when there is.
    """

    idata: xr.DataTree
    diagnostics: Diagnostics
    mu_observed: dict
    surfaces: tuple
    n_samples_used: int
    model: str
    slip_variance_inflation: tuple
    adequacy: Adequacy
    force_range: float
    secant_stiffness: np.ndarray
    provenance: Provenance | None = None
    lateral: LateralFit | None = None
    lateral_reason: str = ""

    @property
    def converged(self) -> bool:
        return bool(self.diagnostics.converged)

    @property
    def fit(self) -> Fit:
        """This fit in the one result type; its ``data.attrs`` carry the tyre-specific fields."""
        data = self.idata.copy()
        data.attrs.update(
            {
                "mu_observed": json.dumps({s: bool(v) for s, v in self.mu_observed.items()}),
                "surfaces": json.dumps(list(self.surfaces)),
                "n_samples_used": int(self.n_samples_used),
                "tyre_model": self.model,
                "slip_variance_inflation": json.dumps(
                    [float(x) for x in self.slip_variance_inflation]
                ),
                "adequacy": json.dumps(self.adequacy.as_dict()),
                "force_range": float(self.force_range),
                "secant_stiffness": json.dumps([float(x) for x in self.secant_stiffness]),
                "lateral_reason": self.lateral_reason,
            }
        )
        if self.lateral is not None:
            data[LATERAL_NODE] = _lateral_node(self.lateral)
        prov = self.provenance or Provenance(method=self.diagnostics.method, model=self.model)
        return Fit(data=data, diagnostics=self.diagnostics, kind="tyre", provenance=prov)

    @classmethod
    def from_fit(cls, fit: Fit) -> TyreFit:
        """The tyre fit a :class:`~tyrebayes.inference.result.Fit` of kind "tyre" holds."""
        if fit.kind != "tyre":
            raise ValueError(f"fit: expected a tyre fit, got a {fit.kind} fit")
        attrs = fit.data.attrs
        return cls(
            idata=fit.data,
            diagnostics=fit.diagnostics,
            mu_observed=fit.attr("mu_observed"),
            surfaces=tuple(fit.attr("surfaces")),
            n_samples_used=int(attrs["n_samples_used"]),
            model=str(attrs["tyre_model"]),
            slip_variance_inflation=tuple(fit.attr("slip_variance_inflation")),
            adequacy=Adequacy.from_dict(fit.attr("adequacy")),
            force_range=float(attrs["force_range"]),
            secant_stiffness=np.asarray(fit.attr("secant_stiffness"), dtype=float),
            provenance=fit.provenance,
            lateral=_lateral_from_node(fit.data),
            lateral_reason=str(attrs.get("lateral_reason", "")),
        )

    def save(self, path) -> Path:
        """Write the fit to netCDF (:meth:`tyrebayes.inference.result.Fit.save`)."""
        return self.fit.save(path)

    def draws(self, name: str) -> np.ndarray:
        """Posterior draws of a variable, chains and draws flattened on the first axis."""
        values = np.asarray(self.idata["posterior"][name])
        return values.reshape((-1,) + values.shape[2:])

    def summary(self) -> dict:
        """The ``fit-tyre --json`` object: c_x, c_xr, mu_max, slip_offset summaries and flags.

        ``mu_max``, ``slip_offset`` and ``force_gain`` (measured over true ρ_x: load share, IMU
        scale, body pitch) describe the first surface and drive; ``load_sensitivity`` is q, of
        C_x ∝ exp(q ΔF_z/F_z,static); ``mu_max_by_surface`` lists
        every surface. ``diagnostics`` is :meth:`Diagnostics.as_dict`; ``adequate`` and
        ``adequacy_reasons`` repeat its model-adequacy verdict at the top level.
        """
        mu = self.draws("mu_max")
        summary = {
            "c_x": summarize(self.draws("c_x")).to_dict(),
            "c_xr": summarize(self.draws("c_xr")).to_dict(),
            "mu_max": summarize(mu[:, 0]).to_dict(),
            "slip_offset": summarize(self.draws("slip_offset")[:, 0]).to_dict(),
            "force_gain": summarize(self.draws("force_gain")[:, 0]).to_dict(),
            "mu_max_observed": bool(self.mu_observed[self.surfaces[0]]),
            "mu_max_by_surface": {
                s: {**summarize(mu[:, i]).to_dict(), "observed": bool(self.mu_observed[s])}
                for i, s in enumerate(self.surfaces)
            },
            "converged": self.converged,
            "adequate": bool(self.diagnostics.adequate),
            "adequacy_reasons": list(self.diagnostics.adequacy_reasons),
            "diagnostics": self.diagnostics.as_dict(),
            "method": self.diagnostics.method,
            "model": self.model,
            "n_samples_used": self.n_samples_used,
            "slip_variance_inflation": [float(x) for x in self.slip_variance_inflation],
            "n_abs_windows": int(np.asarray(self.idata["constant_data"]["at_limit"]).sum()),
            "noise_scales": {
                "slip": float(np.mean(self.draws("slip_noise_scale"))),
                "force": float(np.mean(self.draws("rho_noise_scale"))),
            },
            "identified": {
                "force_range": self.force_range,
                "secant_stiffness": summarize(self.secant_stiffness).to_dict(),
            },
        }
        summary["lateral"] = None if self.lateral is None else self.lateral.to_dict()
        summary["lateral_reason"] = self.lateral_reason
        # Fit files written before the model had a load sensitivity lack it.
        if "load_sensitivity" in self.idata["posterior"]:
            summary["load_sensitivity"] = summarize(self.draws("load_sensitivity")).to_dict()
        return summary


def _lateral_node(lateral: LateralFit) -> xr.DataTree:
    """The lateral fit as a node of the tyre fit's data, its diagnostics and provenance in attrs."""
    node = lateral.fit.data.copy()
    node.attrs = {
        **node.attrs,
        "tyrebayes_diagnostics": json.dumps(_finite_json(lateral.fit.diagnostics.as_dict())),
        "tyrebayes_provenance": json.dumps(lateral.fit.provenance.as_dict()),
    }
    return node


def _lateral_from_node(data: xr.DataTree) -> LateralFit | None:
    if LATERAL_NODE not in data.children:
        return None
    node = data[LATERAL_NODE].copy()
    attrs = dict(node.attrs)
    prov = json.loads(attrs.pop("tyrebayes_provenance"))
    diagnostics = Diagnostics.from_dict(json.loads(attrs.pop("tyrebayes_diagnostics")))
    node.attrs = attrs
    fit = Fit(
        data=node,
        diagnostics=diagnostics,
        kind="lateral",
        provenance=Provenance.from_dict(prov),
    )
    return LateralFit.from_fit(fit)
