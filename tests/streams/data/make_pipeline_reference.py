"""Write the stream-pipeline reference fixture (run once, on the code before a speed change).

``python tests/streams/data/make_pipeline_reference.py`` writes two small input drives
(``pipeline_reference_*.parquet``: a simulated drive with jittered time stamps and dropped
samples, so the resampling path runs; a synthetic drive on a uniform time base) and
``pipeline_reference.json``: per output array of ``validate_stream`` + ``compute_features``,
fingerprints (finite count, sums, a weighted sum, values at fixed indices) that
``tests/streams/test_pipeline_reference.py`` compares the current code against. Speed work
keeps it; a change meant to move the numbers (a physics term) rewrites the fingerprints alone,
from the same input drives, with ``--fingerprints-only``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
INPUTS = {
    "simulated_fwd": ("compact_fwd", "pipeline_reference_simulated.parquet"),
    "synthetic_rav4": ("suv_rav4", "pipeline_reference_synthetic.parquet"),
}


def fingerprint(x) -> dict:
    """Order-sensitive summary of an array: enough to catch any change beyond rounding."""
    a = np.asarray(x, dtype=float)
    if a.size == 0:
        return {"shape": list(a.shape), "finite": 0}
    flat = a.reshape(a.shape[0], -1) if a.ndim else a.reshape(1, 1)
    finite = np.isfinite(flat)
    clean = np.where(finite, flat, 0.0)
    rng = np.random.default_rng(0)
    weights = rng.uniform(0.5, 1.5, flat.shape)
    idx = np.linspace(0, flat.shape[0] - 1, 97).astype(int)
    picks = flat[idx]
    return {
        "shape": list(a.shape),
        "finite": int(finite.sum()),
        "nan_pattern": int((np.flatnonzero(~finite.ravel()) % 1_000_003).sum()),
        "sum": float(clean.sum()),
        "abs_sum": float(np.abs(clean).sum()),
        "weighted_sum": float((clean * weights).sum()),
        "picks": [None if not np.isfinite(v) else float(v) for v in picks.ravel()],
    }


def pipeline_outputs(path: Path, vehicle_name: str) -> dict:
    """Every array and scalar that read + validate + features produce, by name."""
    import dataclasses

    from tyrebayes._domain import load_vehicle
    from tyrebayes.streams import compute_features, read_stream, validate_stream

    vehicle = load_vehicle(vehicle_name)
    stream = validate_stream(read_stream(path), vehicle)
    feats = compute_features(stream, vehicle)
    out: dict = {}
    for col in stream.data.columns:
        out[f"stream.data.{col}"] = stream.data[col].to_numpy(dtype=float)
    out["stream.filled"] = stream.filled
    out["stream.sample_rate_hz"] = stream.sample_rate_hz
    for name in ("nan_fraction", "channel_rate_hz", "quantisation", "noise"):
        for key, value in getattr(stream, name).items():
            out[f"stream.{name}.{key}"] = value
    out["stream.gaps"] = np.asarray(stream.gaps, dtype=float).reshape(-1)
    out["stream.flags"] = list(stream.flags)
    out["stream.notes"] = list(stream.notes)

    def walk(prefix, obj):
        for f in dataclasses.fields(obj):
            value = getattr(obj, f.name)
            key = f"{prefix}.{f.name}"
            if dataclasses.is_dataclass(value):
                walk(key, value)
            elif isinstance(value, dict):
                for k, v in value.items():
                    out[f"{key}.{k}"] = v
            elif isinstance(value, str):
                out[key] = value
            else:
                out[key] = np.asarray(value)

    walk("features", feats)
    return out


def summarise(outputs: dict) -> dict:
    result = {}
    for key, value in outputs.items():
        text = isinstance(value, list) and all(isinstance(v, str) for v in value)
        if isinstance(value, str) or text:  # flags, notes, labels: compared as they are
            result[key] = {"text": value}
        else:
            result[key] = fingerprint(value)
    return result


def main(fingerprints_only: bool = False) -> None:
    import jax

    # As the tests run (tests/conftest.py): the force balance in float64.
    jax.config.update("jax_enable_x64", True)
    from tyrebayes._domain import load_vehicle
    from tyrebayes.simulate.drive import simulate_drive
    from tyrebayes.streams import write_stream
    from tyrebayes.streams.synthetic import synthetic_stream

    if not fingerprints_only:
        df, _ = simulate_drive(3, "compact_fwd", "winter", duration_s=90.0, surface="snow")
        write_stream(df, HERE / INPUTS["simulated_fwd"][1])
        df, _ = synthetic_stream(
            load_vehicle("suv_rav4"), duration_s=90.0, rate_hz=100.0, seed=1, drop_fraction=0.01
        )
        write_stream(df, HERE / INPUTS["synthetic_rav4"][1])
    reference = {
        name: summarise(pipeline_outputs(HERE / file, vehicle))
        for name, (vehicle, file) in INPUTS.items()
    }
    (HERE / "pipeline_reference.json").write_text(json.dumps(reference, indent=0) + "\n")


if __name__ == "__main__":
    import sys

    main(fingerprints_only="--fingerprints-only" in sys.argv[1:])
