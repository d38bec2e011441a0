"""One result type for every fit: the posterior as ArviZ data, its diagnostics, kind and provenance.

Every fitter of the package (per-tyre, fleet, wear, V_max's extended model) returns a
:class:`Fit` or, for the per-tyre model, an object wrapping one (``TyreFit.fit``):

* ``data`` — an ``xarray.DataTree`` in ArviZ's layout (arviz-base: groups ``posterior``,
  ``observed_data``, ``log_likelihood``, ``posterior_predictive``, ``constant_data``,
  ``sample_stats``); what a kind needs to predict from a loaded fit lives there too;
* ``diagnostics`` — a :class:`Diagnostics` computed by :func:`diagnose`, the only place where
  R-hat and effective sample sizes are computed, under the one :data:`POLICY`;
* ``kind`` — the kind of fit, one of :data:`FIT_KINDS` (``"tyre"``, ``"fleet"``, ``"wear"``, ...);
* ``provenance`` — the method, the model variant, the inputs and the package version.

A fit that did not converge, or whose model does not describe its data, says so in its
diagnostics; it is returned as data, never raised. :meth:`Fit.save` and :func:`load_fit` write and
read one file format (netCDF through ``DataTree.to_netcdf``).
"""

from __future__ import annotations

import importlib.metadata
import json
import math
import os
from collections.abc import Sequence
from pathlib import Path

import equinox as eqx
import numpy as np
import xarray as xr

from .._errors import BadInputError
from .._io import atomic_path

# The diagnostics are part of the result type's contract: re-exported here.
from .diagnostics import APPROXIMATE_METHODS as APPROXIMATE_METHODS
from .diagnostics import FIT_METHODS as FIT_METHODS
from .diagnostics import LAPLACE_METHODS as LAPLACE_METHODS
from .diagnostics import MCMC_METHODS as MCMC_METHODS
from .diagnostics import POLICY as POLICY
from .diagnostics import ConvergencePolicy as ConvergencePolicy
from .diagnostics import Diagnostics as Diagnostics
from .diagnostics import diagnose as diagnose
from .diagnostics import hdi as hdi
from .diagnostics import loo as loo
from .diagnostics import posterior_predictive_adequacy as posterior_predictive_adequacy

#: The kinds of fit, one per fitter.
FIT_KINDS: tuple[str, ...] = ("tyre", "fleet", "wear", "vmax", "wear_history", "lateral")
try:
    PACKAGE_VERSION = importlib.metadata.version("tyrebayes")
except importlib.metadata.PackageNotFoundError:  # run from a source tree that is not installed
    PACKAGE_VERSION = "unknown"
#: Version of the saved-fit layout (``attrs["tyrebayes_fit_format"]``).
FILE_FORMAT = 1
#: xarray's netCDF engine for fit files: the netCDF-C library. A fleet set's fit file (no pointwise
#: draws) took 0.018 s to write and 0.013 s to read with it, 0.082 and 0.078 s with h5netcdf, the
#: other engine xarray offers (the ``fit_file_io`` benchmark; a set's fast fit takes about half a
#: second, the ``fleet_run`` benchmark). Each library reads the other's files back identical.
NETCDF_ENGINE = "netcdf4"


class Provenance(eqx.Module):
    """Where a fit came from.

    Attributes
    ----------
    method : str
        Fitting method, one of :data:`~tyrebayes.inference.diagnostics.FIT_METHODS`.
    model : str
        Model variant (tyre curve ``"shaped"``/``"brush"``/``"linear"``; ``"baseline"`` or
        ``"extended"`` for wear; ``"hierarchical"`` for the fleet).
    inputs : tuple of str
        The input files or tables (paths, or a description when built in memory).
    settings : str
        The fitter's settings as JSON (seed, chains, draws, ...).
    package_version : str
        tyrebayes version that made the fit.

    Examples
    --------
    >>> from tyrebayes.inference.result import provenance
    >>> p = provenance("nuts", "hierarchical", ("fleet.csv",), seed=0)
    >>> p.method, p.settings
    ('nuts', '{"seed": 0}')
    """

    method: str
    model: str
    inputs: tuple[str, ...] = ()
    settings: str = "{}"
    package_version: str = ""

    def __check_init__(self):
        json.loads(self.settings)  # a ValueError names the bad JSON

    def as_dict(self) -> dict:
        return {
            "method": self.method,
            "model": self.model,
            "inputs": list(self.inputs),
            "settings": json.loads(self.settings),
            "package_version": self.package_version,
        }

    @classmethod
    def from_dict(cls, d: dict) -> Provenance:
        """Inverse of :meth:`as_dict` (a loaded fit's provenance)."""
        return cls(
            method=d["method"],
            model=d["model"],
            inputs=tuple(d["inputs"]),
            settings=json.dumps(d["settings"], sort_keys=True),
            package_version=d["package_version"],
        )


def provenance(
    method: str, model: str, inputs: Sequence[str] = (), **settings: float | int | str | bool
) -> Provenance:
    """A :class:`Provenance` with this package's version and the settings as JSON."""
    return Provenance(
        method=method,
        model=model,
        inputs=tuple(str(i) for i in inputs),
        settings=json.dumps(settings, sort_keys=True),
        package_version=PACKAGE_VERSION,
    )


class Fit(eqx.Module):
    """The result of every fitter (module docstring).

    Attributes
    ----------
    data : xarray.DataTree
        ArviZ data: posterior, observed data, log-likelihood, posterior predictive, constant
        data and (NUTS) sample statistics; kind-specific attributes in ``data.attrs``.
    diagnostics : Diagnostics
    kind : str
        One of :data:`FIT_KINDS`.
    provenance : Provenance

    Examples
    --------
    A fit made by hand from draws (the fitters make theirs the same way):

    >>> import arviz_base as azb
    >>> draws = np.random.default_rng(0).normal(30.0, 1.0, (1, 400))
    >>> tree = azb.from_dict({"posterior": {"c_xr": draws}})
    >>> fit = Fit(
    ...     data=tree,
    ...     diagnostics=diagnose(tree, method="laplace", optimiser_result="successful"),
    ...     kind="tyre",
    ...     provenance=provenance("laplace", "magic", ["drive.csv"], seed=0),
    ... )
    >>> fit.converged, fit.draws("c_xr").shape
    (True, (400,))
    """

    data: xr.DataTree
    diagnostics: Diagnostics
    kind: str
    provenance: Provenance

    def __check_init__(self):
        if self.kind not in FIT_KINDS:
            raise ValueError(f"kind: expected one of {FIT_KINDS}, got {self.kind!r}")
        if "posterior" not in self.data.children:
            raise ValueError(f"data: expected a posterior group, got {list(self.data.children)}")

    @property
    def converged(self) -> bool:
        return bool(self.diagnostics.converged)

    @property
    def adequate(self) -> bool:
        return bool(self.diagnostics.adequate)

    @property
    def posterior(self) -> xr.DataTree:
        return self.data["posterior"]

    def draws(self, name: str) -> np.ndarray:
        """Posterior draws of a variable, chains and draws flattened on the first axis."""
        if name not in self.posterior.data_vars:
            raise KeyError(
                f"{self.kind} fit: expected a posterior variable, got {name!r} "
                f"(have {sorted(self.posterior.data_vars)})"
            )
        values = np.asarray(self.posterior[name])
        return values.reshape((-1,) + values.shape[2:])

    def attr(self, name: str):
        """A kind-specific attribute stored as JSON in ``data.attrs``."""
        if name not in self.data.attrs:
            raise KeyError(f"{self.kind} fit: expected attribute {name!r}, not found")
        return json.loads(self.data.attrs[name])

    def save(self, path: str | os.PathLike) -> Path:
        """Write the fit (data, diagnostics, kind, provenance) to a netCDF file, atomically.

        The temporary file beside ``path`` is renamed into place, so a reader never sees a
        half-written fit. Returns the final path. Read back with :func:`load_fit`.
        """
        tmp, path = atomic_path(path)
        tree = self.data.copy()
        tree.attrs = {
            **tree.attrs,
            "tyrebayes_fit_format": FILE_FORMAT,
            "tyrebayes_kind": self.kind,
            "tyrebayes_diagnostics": json.dumps(_finite_json(self.diagnostics.as_dict())),
            "tyrebayes_provenance": json.dumps(self.provenance.as_dict()),
        }
        try:
            tree.to_netcdf(tmp, engine=NETCDF_ENGINE)
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)
        return path


def _finite_json(d: dict) -> dict:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


def load_fit(path: str | os.PathLike, *, kind: str | None = None) -> Fit:
    """Read a fit written by :meth:`Fit.save` (any kind, or the ``kind`` given).

    Parameters
    ----------
    path : str or path-like
        The fit file (netCDF).
    kind : str, optional
        The kind expected (one of :data:`FIT_KINDS`); a fit of another kind is refused.

    Returns
    -------
    Fit

    Raises
    ------
    BadInputError
        Naming what was expected for a missing file, a file that is not a saved fit, or a fit
        of another kind.

    Examples
    --------
    >>> import tempfile
    >>> import arviz_base as azb
    >>> tree = azb.from_dict({"posterior": {"gamma": np.ones((1, 100))}})
    >>> fit = Fit(
    ...     data=tree,
    ...     diagnostics=diagnose(tree, method="laplace", optimiser_result="successful"),
    ...     kind="wear",
    ...     provenance=provenance("laplace", "wear", ["readings.csv"]),
    ... )
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     loaded = load_fit(fit.save(Path(folder) / "wear.nc"), kind="wear")
    >>> loaded.kind, loaded.provenance == fit.provenance
    ('wear', True)
    """
    p = Path(path)
    if not p.is_file():
        raise BadInputError(f"file not found: expected a readable fit file, got '{path}'")
    expected = f"a {kind} fit" if kind else "a saved fit"
    try:
        with xr.open_datatree(p, engine=NETCDF_ENGINE) as opened:
            tree = opened.load()
    except (OSError, ValueError, KeyError) as err:
        raise BadInputError(f"fit file {path}: expected {expected} (netCDF), got {err}") from None
    attrs = dict(tree.attrs)
    if "tyrebayes_kind" not in attrs:
        raise BadInputError(f"fit file {path}: expected {expected}, got a file without one")
    if kind is not None and attrs["tyrebayes_kind"] != kind:
        raise BadInputError(
            f"fit file {path}: expected {expected}, got a {attrs['tyrebayes_kind']} fit"
        )
    prov = json.loads(attrs.pop("tyrebayes_provenance"))
    diagnostics = Diagnostics.from_dict(json.loads(attrs.pop("tyrebayes_diagnostics")))
    fit_kind = str(attrs.pop("tyrebayes_kind"))
    attrs.pop("tyrebayes_fit_format", None)
    tree.attrs = attrs
    return Fit(
        data=tree,
        diagnostics=diagnostics,
        kind=fit_kind,
        provenance=Provenance.from_dict(prov),
    )
