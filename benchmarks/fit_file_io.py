"""Writing and reading a saved fit: the netCDF libraries xarray can use, on one fit file.

A fleet run saves a fit file per tyre set and ``criticize`` / ``predict`` read them back, so the
file's write and read are part of every set's cost. The fit is a fast fit of one simulated one-hour
drive (compact FWD car, summer tyres, two ABS stops), saved as
:meth:`tyrebayes.inference.result.Fit.save` writes it. Each engine installed (``netcdf4``, the
package's :data:`~tyrebayes.inference.result.NETCDF_ENGINE`; ``h5netcdf``, which the package used
before, where installed) writes the same tree ``--repeats`` times and reads it back as
:func:`~tyrebayes.inference.result.load_fit` does; the median of each is kept, with the file sizes
and whether each engine's file reads back identical to the tree written (values, dtypes,
attributes), and whether each reads the other's file identical too: the file with the per-window
pointwise draws (``fit-tyre``'s default) and without them (as ``fleet-run`` saves a set's fit). The
package's own ``save`` and ``load_fit`` are timed too (with them).

Usage: ``python benchmarks/fit_file_io.py [--repeats N] [--out PATH]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

from _results import write_result  # noqa: E402

RESULTS = Path(__file__).parent / "results" / "fit_file_io.json"
ENGINES = ("netcdf4", "h5netcdf")


def one_hour_fit():
    from tyrebayes import (
        compute_features,
        fit_tyre,
        load_vehicle,
        observations_from_features,
        stack_drives,
        validate_stream,
    )
    from tyrebayes.simulate import ProfileOptions, simulate_drive

    vehicle = load_vehicle("compact_fwd")
    df, truth = simulate_drive(
        0, vehicle, "summer", duration_s=3600.0, profile=ProfileOptions(n_abs_events=2)
    )
    features = compute_features(validate_stream(df, vehicle), vehicle)
    obs = stack_drives([observations_from_features(features)], [truth.surface])
    return fit_tyre(obs, method="fast")


def _median_seconds(action, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()

    import jax

    jax.config.update("jax_enable_x64", True)
    import xarray as xr
    from _internal import NETCDF_ENGINE

    from tyrebayes import load_fit

    fit = one_hour_fit()
    folder = Path(tempfile.mkdtemp(prefix="fit_file_io_"))
    saved = fit.save(folder / "package.fit.nc")
    with xr.open_datatree(saved, engine=NETCDF_ENGINE) as opened:
        tree = opened.load()  # the tree as saved, with the file's attributes
    # As fleet-run saves a set's fit: without the per-window pointwise draws.
    trees = {
        "with_pointwise": tree,
        "without_pointwise": tree.drop_nodes(["log_likelihood", "posterior_predictive"]),
    }
    engines = {}
    for engine in ENGINES:
        if importlib.util.find_spec("netCDF4" if engine == "netcdf4" else engine) is None:
            engines[engine] = {"installed": False}
            continue
        engines[engine] = {"installed": True}
        for label, written in trees.items():
            path = folder / f"{engine}_{label}.nc"

            def write(e=engine, p=path, t=written):
                t.to_netcdf(p, engine=e)

            def read(e=engine, p=path):
                with xr.open_datatree(p, engine=e) as opened:
                    return opened.load()

            engines[engine][label] = {
                "write_seconds_median": _median_seconds(write, args.repeats),
                "read_seconds_median": _median_seconds(read, args.repeats),
                "file_mb": path.stat().st_size / 2**20,
                "reads_back_identical": bool(read().identical(written)),
            }
    # Each engine reading the other's file: the old fit files stay readable.
    installed = [e for e in ENGINES if engines[e]["installed"]]
    for engine in installed:
        for other in installed:
            if other != engine:
                for label, written in trees.items():
                    path = folder / f"{other}_{label}.nc"
                    with xr.open_datatree(path, engine=engine) as opened:
                        same = bool(opened.load().identical(written))
                    engines[engine][label][f"reads_{other}_file_identical"] = same
    package = {
        "engine": NETCDF_ENGINE,
        "save_seconds_median": _median_seconds(
            lambda: fit.save(folder / "package.fit.nc"), args.repeats
        ),
        "load_fit_seconds_median": _median_seconds(lambda: load_fit(saved), args.repeats),
    }
    results = {
        "benchmark": "fit_file_io",
        "fit": "fast fit of one simulated one-hour drive (compact_fwd, summer, 2 ABS stops)",
        "variables": {k: sum(len(n.data_vars) for n in t.subtree) for k, t in trees.items()},
        "groups": {k: [n.path for n in t.subtree] for k, t in trees.items()},
        "repeats": args.repeats,
        "engines": engines,
        "package": package,
        "load_average_1min": os.getloadavg()[0],
        "cpu_count": os.cpu_count(),
    }
    print(json.dumps(results, indent=1))
    print(f"saved {write_result('fit_file_io', results, path=args.out)}")
    for path in folder.iterdir():
        path.unlink()
    folder.rmdir()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
