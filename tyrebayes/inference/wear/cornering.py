"""The cornering stiffness behind the wear evidence's lateral work, from a lateral posterior.

The lateral friction work W_y = ∫ F_y V_x tan α dt (thesis eq. 4.19b) needs each axle's slip
angle, which the forces alone do not give: it takes the axle's cornering stiffness c_y. Where a
lateral fit of the car exists (:func:`~tyrebayes.inference.lateral.fit.fit_lateral`, or the
``lateral`` part of a tyre fit), :func:`cornering_stiffness_from_lateral` turns its per-axle c_y
posterior into the :class:`~tyrebayes.streams.cornering_stiffness.CorneringStiffness` that
:func:`~tyrebayes.streams.wear_evidence.drive_wear_evidence` takes; without one the evidence uses
the type prior :data:`~tyrebayes.streams.cornering_stiffness.TYPE_PRIOR_CORNERING`. A drive
history's own drives carry the cornering that fit needs:
:func:`cornering_stiffness_from_drives` fits them in turn until one gives a usable fit.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable

import equinox as eqx
import numpy as np
import pandas as pd

from ...streams.cornering_stiffness import CorneringStiffness
from ..lateral.result import LateralFit
from ..result import Fit
from ..tyre.result import LATERAL_NODE, TyreFit

#: Drives of a history the lateral fit is tried on, in order, until one is usable. Each try is a
#: lateral fit of one drive: the bound keeps a history of straight drives from paying one per
#: drive.
LATERAL_TRIES = 5


def cornering_stiffness_from_draws(
    c_y_front: np.ndarray, c_y_rear: np.ndarray, source: str = "lateral_fit"
) -> CorneringStiffness:
    """Medians of per-axle c_y draws [1/rad] and the larger of their log-sds.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> c = cornering_stiffness_from_draws(
    ...     20.0 * np.exp(0.1 * rng.standard_normal(4000)),
    ...     24.0 * np.exp(0.05 * rng.standard_normal(4000)),
    ... )
    >>> round(c.front_per_rad), round(c.rear_per_rad), round(c.log_sd, 2), c.source
    (20, 24, 0.1, 'lateral_fit')
    """
    draws = [np.asarray(c, dtype=float).ravel() for c in (c_y_front, c_y_rear)]
    for name, d in zip(("c_y_front", "c_y_rear"), draws, strict=True):
        if d.size < 2 or not np.all(np.isfinite(d) & (d > 0)):
            raise ValueError(f"{name}: expected at least 2 finite draws > 0, got {d.size} draws")
    log_sd = max(float(np.std(np.log(d))) for d in draws)
    return CorneringStiffness(
        float(np.median(draws[0])), float(np.median(draws[1])), log_sd, source
    )


def cornering_stiffness_from_lateral(lateral: LateralFit) -> CorneringStiffness:
    """The per-axle c_y of a lateral fit for the wear evidence (``source`` ``"lateral_fit"``).

    Parameters
    ----------
    lateral : LateralFit
        A lateral fit of the car (its posterior of ``c_y_front`` and ``c_y_rear`` [1/rad]).

    Returns
    -------
    CorneringStiffness
        Posterior medians and the larger of the two posterior log-sds.

    Examples
    --------
    >>> fit = fit_lateral(cornering_observations(frame, vehicle))  # doctest: +SKIP
    >>> cornering_stiffness_from_lateral(fit).source  # doctest: +SKIP
    'lateral_fit'
    """
    return cornering_stiffness_from_draws(
        lateral.draws("c_y_front"), lateral.draws("c_y_rear"), "lateral_fit"
    )


def cornering_stiffness_from_tyre_fit(fit: Fit) -> CorneringStiffness | None:
    """The per-axle c_y of a saved tyre fit's lateral part, or None where it has none to use.

    Parameters
    ----------
    fit : Fit
        A tyre fit (:func:`~tyrebayes.inference.result.load_fit` of ``fit-tyre --out``).

    Returns
    -------
    CorneringStiffness or None
        ``source`` ``"lateral_fit"``; None without a lateral posterior (no usable cornering) or
        with one not to be used (:meth:`.LateralFit.unusable_reason`).

    Examples
    --------
    >>> cornering_stiffness_from_tyre_fit(load_fit("tyre.nc"))  # doctest: +SKIP
    """
    if LATERAL_NODE not in fit.data.children:
        return None
    lateral = TyreFit.from_fit(fit).lateral
    if lateral is None or lateral.unusable_reason():
        return None
    return cornering_stiffness_from_lateral(lateral)


class DrivesCornering(eqx.Module):
    """The cornering stiffness a drive history's own drives give, and what each try gave.

    Attributes
    ----------
    stiffness : CorneringStiffness or None
        From the first usable lateral fit (``source`` ``"lateral_fit"``); None when no drive
        tried gave one.
    drive : str
        The drive whose fit gave it ("" when none did).
    tries : tuple of (str, str)
        Each drive tried and why its fit was not used ("" for the one used).

    Examples
    --------
    >>> found = DrivesCornering(None, "", (("drive_000", "lateral: no usable cornering"),))
    >>> found.note.endswith("no usable cornering): the type prior's c_y is used")
    True
    """

    stiffness: CorneringStiffness | None
    drive: str
    tries: tuple[tuple[str, str], ...]

    @property
    def note(self) -> str:
        """One line: which drive's lateral fit gave the c_y, or why the type prior's is used."""
        if self.stiffness is not None:
            return f"c_y from the lateral fit of {self.drive}"
        if not self.tries:
            return "no drive to fit the cornering of: the type prior's c_y is used"
        last_drive, last_reason = self.tries[-1]
        return (
            f"no usable lateral fit among the first {len(self.tries)} drives (last, "
            f"{last_drive}: {last_reason}): the type prior's c_y is used"
        )


def cornering_stiffness_from_drives(
    frames: Iterable[tuple[str, pd.DataFrame]],
    vehicle,
    *,
    tries: int = LATERAL_TRIES,
    seed: int = 0,
) -> DrivesCornering:
    """The per-axle c_y of the first of a history's drives whose lateral fit is usable.

    Each drive is fitted with the lateral model
    (:func:`~tyrebayes.inference.lateral.fit.fit_lateral`, its default method) until one fit
    converges and describes its drive (:meth:`.LateralFit.unusable_reason`); at most ``tries``
    drives are fitted. One fit of one drive, not a joint one: its posterior log-sd (about 0.1 on
    ten minutes of commuting) is what the wear model carries as the lateral work's scale error.

    Parameters
    ----------
    frames : iterable of (str, pandas.DataFrame)
        Each drive's name and its validated stream (``ValidatedStream.data``), in driving order;
        taken lazily, so that drives after the usable one are not read.
    vehicle : Vehicle
        The car.
    tries : int
        Most drives fitted.
    seed : int
        Seed of the lateral fits' draws.

    Returns
    -------
    DrivesCornering
        The stiffness (None when no drive tried gave one) and each try's reason.

    Examples
    --------
    A year of drives (``paths``, stream files of the car ``car``) whose third is the first to
    corner enough:

    >>> frames = ((p.stem, validate_stream(read_stream(p), car).data) for p in paths)
    ... # doctest: +SKIP
    >>> cornering_stiffness_from_drives(frames, car).note  # doctest: +SKIP
    'c_y from the lateral fit of drive_002'
    """
    from ..lateral.data import cornering_observations
    from ..lateral.fit import fit_lateral

    if tries < 1:
        raise ValueError(f"tries: expected at least 1, got {tries}")
    tried: list[tuple[str, str]] = []
    for name, frame in itertools.islice(frames, tries):
        try:
            fit = fit_lateral(cornering_observations(frame, vehicle), seed=seed)
        except ValueError as err:  # NoCornering, or a log the model cannot take: its reason
            tried.append((name, str(err).strip().splitlines()[0] if str(err).strip() else ""))
            continue
        reason = fit.unusable_reason()
        tried.append((name, reason))
        if not reason:
            return DrivesCornering(cornering_stiffness_from_lateral(fit), name, tuple(tried))
    return DrivesCornering(None, "", tuple(tried))
