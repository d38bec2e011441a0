"""Stream criticism: the linear-slip baseline against per-segment candidate covariates.

Baseline: rho_x = C_x (sigma_x - s0) for the driven axle, one C_x and one s0 for the whole drive
(thesis eq. 4.27 read forwards), with Gaussian residuals — fitted as an exact conjugate
(Normal-Inverse-Gamma) regression of rho_x on sigma_x with an intercept (-C_x s0). Features come
from :mod:`tyrebayes.streams` (validated stream, V_x from the non-driven wheels, slip, rho_x from
the single-track inverse with load transfer, offset-corrected IMU ax, grade estimate).

The drive is cut into windows (segments); samples are thinned to one per ``thin_s`` to reduce the
autocorrelation the 0.2 s smoothing introduces, and leave-one-out leaves out whole segments
(PSIS on the per-segment summed log-likelihood; exact leave-segment-out where Pareto k > 0.7).
Candidates are per-segment summaries: speed, acceleration, braking share, grade / IMU-offset
proxy, cornering (|yaw rate|, |ay|, |steer|), radius mismatch against a GNSS reference, vertical
acceleration, time and temperature when logged. They are scanned on the segment means of the
baseline residuals (degrees of freedom of segments, not of autocorrelated samples).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from .._domain import load_vehicle
from .._errors import BadInputError
from ..inference.summary import summarize
from ..physics.vehicle import Vehicle
from ..streams import compute_features, read_stream, validate_stream
from ..streams.validate import ValidatedStream
from .linear import difference, fit_and_loo, loo_from_pointwise
from .ppc import posterior_predictive_check
from .scan import (
    CANDIDATE_PRIOR_VAR,
    ELPD_SE_FACTOR,
    Candidate,
    CriticismResult,
    criticize_linear,
)

#: Default number of segments the drive is cut into when no window is given (at most 10 s each).
TARGET_SEGMENTS = 20
MAX_WINDOW_S = 10.0
MIN_WINDOW_S = 1.0
MIN_SAMPLES_PER_SEGMENT = 4


def _load(stream, vehicle, brake_front_share: float):
    """The validated stream, the vehicle and the stream's features, from what the caller gave."""
    if not isinstance(vehicle, Vehicle):
        try:
            vehicle = load_vehicle(vehicle)
        except (FileNotFoundError, KeyError, ValueError) as err:
            raise BadInputError(
                f"vehicle: expected a preset name or TOML path, got '{vehicle}' ({err})"
            ) from err
    if isinstance(stream, str | os.PathLike):
        stream = read_stream(Path(stream))
    if isinstance(stream, pd.DataFrame):
        stream = validate_stream(stream, vehicle)
    if not isinstance(stream, ValidatedStream):
        raise BadInputError(
            f"stream: expected a path, DataFrame or ValidatedStream, got {type(stream).__name__}"
        )
    return stream, vehicle, compute_features(stream, vehicle, brake_front_share=brake_front_share)


def _segment_mean(values: np.ndarray, seg: np.ndarray, n_seg: int) -> np.ndarray:
    """Mean of the finite values of each segment (NaN where it has none)."""
    ok = np.isfinite(values)
    total = np.bincount(seg[ok], weights=values[ok], minlength=n_seg)
    count = np.bincount(seg[ok], minlength=n_seg)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _standardise(v: np.ndarray) -> tuple[np.ndarray, float]:
    """``v`` centred and scaled by its sd (1 where that is 0), and the sd."""
    sd = float(np.nanstd(v))
    sd = sd if sd > 0 else 1.0
    return (v - np.nanmean(v)) / sd, sd


def stream_design(
    stream,
    vehicle,
    *,
    window_s: float | None = None,
    thin_s: float = 0.25,
    brake_front_share: float = 0.7,
):
    """Rows, segments, baseline design and per-segment candidates of a stream.

    Returns
    -------
    dict
        ``y`` (standardised rho_x), ``x0``, ``prior0``, ``y_scale``, ``sigma_scale``, ``units``
        (segment index per row), ``candidates`` (list of Candidate), ``segments`` (DataFrame of
        per-segment candidate values), ``window_s``, ``n_rows``, ``notes``.
    """
    validated, vehicle, f = _load(stream, vehicle, brake_front_share)
    notes = list(getattr(validated, "notes", ()))
    t = f.time_s
    duration = float(t[-1] - t[0])
    if window_s is None:
        window_s = float(np.clip(duration / TARGET_SEGMENTS, MIN_WINDOW_S, MAX_WINDOW_S))
    seg = _segments(f, window_s, thin_s)
    idx, units, n_seg = seg.rows, seg.units, seg.n_segments
    cand_values = _candidate_values(f, validated.data, seg)
    candidates = _segment_candidates(cand_values, units)

    rho = f.rho_driven[idx]
    slip = f.slip_driven[idx]
    y, y_scale = _standardise(rho)
    s_std, s_scale = _standardise(slip)
    x0 = np.column_stack([np.ones(idx.size), s_std])
    segments = pd.DataFrame(cand_values)
    segments.insert(0, "segment", np.arange(n_seg))
    return {
        "y": y,
        "x0": x0,
        "prior0": np.array([100.0, 25.0]),
        "y_scale": y_scale,
        "y_mean": float(np.mean(rho)),
        "sigma_scale": s_scale,
        "sigma_mean": float(np.mean(slip)),
        "units": units,
        "candidates": candidates,
        "segments": segments,
        "window_s": window_s,
        "n_rows": int(idx.size),
        "notes": notes,
        "features": f,
    }


class _Segments(NamedTuple):
    """The thinned rows kept for the baseline and the segments they fall in."""

    rows: np.ndarray  # sample index of each kept row
    units: np.ndarray  # segment of each kept row
    n_segments: int
    of_sample: np.ndarray  # segment of every sample (0 outside the kept segments)
    in_segment: np.ndarray  # valid samples inside a kept segment

    def mean(self, values: np.ndarray) -> np.ndarray:
        """Per-segment mean of a per-sample signal over the valid samples (NaN where none)."""
        v = np.where(self.in_segment, values, np.nan)
        return _segment_mean(v, self.of_sample, self.n_segments)


def _segments(f, window_s: float, thin_s: float) -> _Segments:
    """Usable rows thinned to one per ``thin_s``, in segments of ``window_s`` with enough rows."""
    t = f.time_s
    rate = float(f.sample_rate_hz)
    step = max(1, int(round(thin_s * rate)))
    use = f.valid & ~f.spin & np.isfinite(f.slip_driven) & np.isfinite(f.rho_driven)
    idx = np.flatnonzero(use)
    idx = idx[(idx - idx[0]) % step == 0] if idx.size else idx
    seg_all = np.floor((t - t[0]) / window_s).astype(int)
    counts = np.bincount(seg_all[idx], minlength=int(seg_all.max()) + 1)
    keep_seg = np.flatnonzero(counts >= MIN_SAMPLES_PER_SEGMENT)
    if keep_seg.size < 6:
        raise BadInputError(
            f"stream: expected at least 6 usable segments of {window_s:.1f} s, got {keep_seg.size}"
        )
    idx = idx[np.isin(seg_all[idx], keep_seg)]
    relabel = np.full(seg_all.max() + 1, -1)
    relabel[keep_seg] = np.arange(keep_seg.size)
    return _Segments(
        rows=idx,
        units=relabel[seg_all[idx]],
        n_segments=keep_seg.size,
        of_sample=np.where(np.isin(seg_all, keep_seg), relabel[seg_all], 0),
        in_segment=np.isin(seg_all, keep_seg) & f.valid,
    )


def _candidate_values(f, data: pd.DataFrame, seg: _Segments) -> dict[str, np.ndarray]:
    """Per-segment means of the candidate covariates (the logged ones where the stream has them)."""
    cand_values: dict[str, np.ndarray] = {
        "speed_mps": seg.mean(f.vx_mps),
        "accel_mps2": seg.mean(f.dvx_dt_mps2),
        "braking_fraction": seg.mean((f.dvx_dt_mps2 < 0).astype(float)),
        "grade_imu_offset_rad": seg.mean(f.grade_rad),
        "abs_yaw_rate_radps": seg.mean(np.abs(f.yaw_rate_radps)),
        "abs_ay_mps2": seg.mean(np.abs(f.ay_mps2)),
        "abs_steer_rad": seg.mean(np.abs(f.steer_rad)),
        "time_s": seg.mean(f.time_s),
    }
    if "speed_reference" in data:
        ref = data["speed_reference"].to_numpy(dtype=float)
        ratio = np.where(ref > 1.0, f.vx_mps / np.where(ref > 1.0, ref, 1.0) - 1.0, np.nan)
        cand_values["radius_mismatch_vs_gnss"] = seg.mean(ratio)
    if "az" in data:
        az = data["az"].to_numpy(dtype=float)
        cand_values["vertical_accel_mps2"] = seg.mean(az - np.nanmedian(az))
    if "ambient_temperature" in data:
        cand_values["ambient_temperature_c"] = seg.mean(
            data["ambient_temperature"].to_numpy(dtype=float)
        )
    return cand_values


def _segment_candidates(cand_values: dict[str, np.ndarray], units: np.ndarray) -> list[Candidate]:
    """Numeric candidates of the covariates that vary over the segments, standardised by row."""
    candidates = []
    for name, v_seg in cand_values.items():
        finite = v_seg[np.isfinite(v_seg)]
        if finite.size < 3 or np.ptp(finite) <= 1e-12 * max(1.0, float(np.abs(finite).max())):
            continue
        v_rows = v_seg[units]
        v_std, sd = _standardise(v_rows)
        candidates.append(Candidate(name, "numeric", v_std[:, None], np.array([sd]), (name,)))
    return candidates


def criticize_stream(
    stream,
    vehicle,
    *,
    window_s: float | None = None,
    thin_s: float = 0.25,
    brake_front_share: float = 0.7,
    alpha: float = 0.05,
    seed: int = 0,
    n_draws: int = 2000,
    se_factor: float = ELPD_SE_FACTOR,
) -> CriticismResult:
    """Criticise the linear-slip model of a stream against per-segment candidates.

    Parameters
    ----------
    stream : path, pandas.DataFrame or ValidatedStream
        A stream in the DESIGN.md contract.
    vehicle : str, path or Vehicle
        Vehicle preset name (e.g. ``"suv_rav4"``), TOML path or :class:`Vehicle`.
    window_s : float or None
        Segment length [s]; default: the drive cut into 20 segments, 1-10 s each.
    thin_s : float
        Keep one sample per ``thin_s`` seconds (reduces autocorrelation) [s].
    brake_front_share : float
        Front share of the braking force assumed by the feature pipeline [-].
    alpha : float
        False-discovery rate of the rule (Benjamini-Hochberg over candidates).
    seed : int
        Seed of the permutations and posterior draws.
    n_draws : int
        Exact posterior draws per model.
    se_factor : float
        A finding's ELPD gain must exceed ``se_factor`` standard errors (default 0); it must be
        positive in any case.

    Returns
    -------
    CriticismResult
        Baseline ELPD (leave-one-segment-out), candidates with ELPD gain, SE and effect in
        rho_x per unit of the covariate, ``found``, notes with the baseline C_x and s0.

    Examples
    --------
    >>> from tyrebayes._resources import data_dir
    >>> result = criticize_stream(data_dir() / "comma2k19_rav4_segment.csv", "suv_rav4")
    >>> result.baseline.pointwise.shape[0] >= 6
    True
    """

    d = stream_design(
        stream, vehicle, window_s=window_s, thin_s=thin_s, brake_front_share=brake_front_share
    )
    base_loo, base_fit, results, found, notes = criticize_linear(
        d["y"],
        d["x0"],
        d["prior0"],
        d["candidates"],
        y_scale=d["y_scale"],
        units=d["units"],
        alpha=alpha,
        seed=seed,
        n_draws=n_draws,
        se_factor=se_factor,
    )
    # Physical parameters of the baseline: rho = C_x (sigma - s0).
    beta = base_fit.beta
    c_x = beta[:, 1] * d["y_scale"] / d["sigma_scale"]
    intercept = d["y_mean"] + beta[:, 0] * d["y_scale"] - c_x * d["sigma_mean"]
    s0 = -intercept / c_x
    cs, ss = summarize(c_x), summarize(s0)
    ppc = _stream_ppc(d, base_fit, seed)
    extended_note = _extended_note(d, found, base_loo, seed, n_draws) if found else []
    header = [
        f"baseline: rho_x = C_x (sigma_x - s0) pooled over {d['n_rows']} thinned samples in "
        f"{base_loo.pointwise.shape[0]} segments of {d['window_s']:.1f} s; "
        f"C_x = {cs.mean:.1f} [{cs.hdi_low:.1f}, {cs.hdi_high:.1f}], "
        f"s0 = {ss.mean:.5f} [{ss.hdi_low:.5f}, {ss.hdi_high:.5f}] (90% HDI)",
        "slip and force taken as exact in the baseline (errors in variables ignored); "
        "segments treated as independent",
    ]
    return CriticismResult(
        baseline=base_loo,
        candidates=results,
        found=found,
        ppc=ppc,
        notes=header + extended_note + d["notes"] + notes,
        alpha=alpha,
    )


def _extended_note(d: dict, found: list[str], base_loo, seed: int, n_draws: int) -> list[str]:
    """C_x, s0 and the ELPD gain of the model extended with every finding."""

    cands = {c.name: c for c in d["candidates"]}
    cols = np.column_stack([cands[name].columns for name in found])
    rows = np.flatnonzero(np.all(np.isfinite(cols), axis=1))
    x1 = np.column_stack([d["x0"], cols])[rows]
    prior1 = np.concatenate([d["prior0"], np.full(cols.shape[1], CANDIDATE_PRIOR_VAR)])
    units = np.unique(d["units"][rows], return_inverse=True)[1]
    rng = np.random.default_rng(seed + 2)
    ext = fit_and_loo(x1, d["y"][rows], prior1, rng, n_draws=n_draws, units=units)
    base = fit_and_loo(d["x0"][rows], d["y"][rows], d["prior0"], rng, n_draws=n_draws, units=units)
    gain, se = difference(loo_from_pointwise(base.loo.pointwise, base.loo.pareto_k, 0), ext.loo)
    c_x = ext.beta[:, 1] * d["y_scale"] / d["sigma_scale"]
    cs = summarize(c_x)
    return [
        f"extended model (baseline + {', '.join(found)}): ELPD gain {gain:.2f} (SE {se:.2f}) "
        f"over the baseline; C_x = {cs.mean:.1f} [{cs.hdi_low:.1f}, "
        f"{cs.hdi_high:.1f}] (90% HDI, slip stiffness with the findings modelled)"
    ]


def _stream_ppc(d: dict, fit, seed: int) -> dict:
    """PPC of the stream baseline: residual autocorrelation and between-segment spread."""
    rng = np.random.default_rng(seed + 1)
    mu = fit.beta @ d["x0"].T
    y_rep = mu + fit.sigma[:, None] * rng.standard_normal(mu.shape)
    units = d["units"]
    n_seg = int(units.max()) + 1
    counts = np.bincount(units, minlength=n_seg).astype(float)

    def seg_spread(r: np.ndarray) -> np.ndarray:
        # sd of the per-segment mean residuals: large when segments differ systematically.
        r2 = np.atleast_2d(r)
        means = np.stack([np.bincount(units, weights=row, minlength=n_seg) for row in r2])
        return (means / counts).std(axis=-1)

    out = posterior_predictive_check(d["y"], y_rep).to_dict()
    r_obs = d["y"][None, :] - mu
    r_rep = y_rep - mu
    for name, fn in (
        ("lag-1 autocorrelation of residuals", _lag1),
        ("sd of segment-mean residuals", seg_spread),
    ):
        t_obs, t_rep = fn(r_obs), fn(r_rep)
        out[name] = {"observed": float(np.mean(t_obs)), "p_value": float(np.mean(t_rep >= t_obs))}
    return out


def _lag1(r: np.ndarray) -> np.ndarray:
    c = r - r.mean(axis=-1, keepdims=True)
    return (c[..., 1:] * c[..., :-1]).sum(axis=-1) / np.maximum((c**2).sum(axis=-1), 1e-300)
