"""The one writer of ``benchmarks/results/*.json``: every benchmark's result goes through it.

A result file is the benchmark's own payload (its figures, per-case rows, settings) with three
keys added at the top level:

``benchmark``
    the benchmark's name (``python -m benchmarks NAME`` runs it; the file is ``NAME.json``).
``run``
    where the figures came from: ``revision`` (``commit``, ``dirty`` and the changed paths when the
    working tree differed from the commit), ``date`` (UTC, ISO 8601), ``quick`` (a reduced run),
    ``machine`` (``cores`` seen, ``cores_usable`` by this process, ``cpu_model``, ``platform``,
    ``python`` and the versions of the numerical libraries), ``wall_s`` and ``cpu_s`` (this process
    and its finished child processes, since the writer was imported, or since ``started``),
    ``peak_rss_mb`` (this process) and ``peak_rss_children_mb`` (its largest finished child; Linux
    counts a child's memory from the fork, so a child of a large process reads at least the
    parent's size then).
``figures``
    the headline figures, each made by :func:`figure`: ``name``, ``value``, ``unit``, ``target``
    (``{"op": "<=", "value": 0.05}`` or ``None``), ``met`` (``None`` without a target), ``count``
    (how many cases the figure summarises) and ``exclusions`` (cases left out, and why).

A script imports it as ``from _results import figure, write_result`` (the script's own folder is
on ``sys.path`` when it runs as ``python benchmarks/NAME.py``, which is how ``python -m
benchmarks NAME`` starts it).

A full run writes ``benchmarks/results/NAME.json`` (the latest run per benchmark; git keeps the
earlier ones). A quick run (``quick=True``) writes ``benchmarks/results/quick/NAME.json``, which git
ignores, so that a smoke test never replaces a measured figure.

Example
-------
>>> from benchmarks._results import figure, write_result
>>> path = write_result(  # doctest: +SKIP
...     "tyre_speed",
...     {"per_drive_s": [0.41, 0.44]},
...     figures=[figure("fit time per drive", 0.43, unit="s", target=("<=", 1.0), count=2)],
... )
"""

from __future__ import annotations

import datetime
import importlib.metadata
import json
import math
import os
import platform
import resource
import subprocess
import sys
import time
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
QUICK_RESULTS = RESULTS / "quick"
#: Set to "1" by ``python -m benchmarks --quick``: the script's result is a quick one.
QUICK_ENV = "TYREBAYES_BENCHMARK_QUICK"

# Keys the writer owns; a payload that uses one of them for something else is refused.
RESERVED = ("benchmark", "run", "figures")

# What a target's comparison means: ``met`` is ``OPS[op](value, bound)``.
OPS = {
    "abs<=": lambda v, b: abs(v) <= b,  # |value| <= bound
    "in": lambda v, b: b[0] <= v <= b[1],  # bound is [low, high]
    "<=": lambda v, b: v <= b,
    "<": lambda v, b: v < b,
    ">=": lambda v, b: v >= b,
    ">": lambda v, b: v > b,
    "==": lambda v, b: v == b,
}

_IMPORTED_WALL = time.perf_counter()
_IMPORTED_CPU = os.times()

_LIBRARIES = ("tyrebayes", "jax", "jaxlib", "numpyro", "optimistix", "equinox", "numpy", "dask")


def figure(
    name: str,
    value: float | int | bool | None,
    *,
    unit: str = "",
    target: tuple[str, float] | None = None,
    met: bool | None = None,
    count: int | None = None,
    exclusions: Iterable[str] | Mapping[str, Any] | None = None,
    note: str = "",
    headline: bool = False,
) -> dict[str, Any]:
    """One figure of a benchmark, as the results schema stores it.

    Parameters
    ----------
    name
        What the figure is, in words a user reads ("median C_x error").
    value
        The measured value (``None`` when it could not be measured).
    unit
        Its unit ("s", "%", "GB"; empty for a ratio or a count).
    target
        ``(op, bound)`` with ``op`` one of ``<=``, ``<``, ``>=``, ``>``, ``==``, ``abs<=``
        (``|value| <= bound``) or ``in`` (``bound`` is ``[low, high]``): the value the
        benchmark was written to reach. ``None`` for a figure reported without a target.
    met
        Whether the target was met; computed from ``target`` when not given. A figure whose target
        is not a plain comparison (a range, a judgement) passes ``met`` itself.
    count
        How many cases (drives, fits, tyre sets) the figure summarises.
    exclusions
        The cases left out of the figure and why (a list of reasons or a mapping case -> reason).
    note
        One line a reader needs to read the figure right.
    headline
        One of the package's headline figures: the README's results table shows it.

    Returns
    -------
    dict
        ``{"name", "value", "unit", "target", "met", "count", "exclusions", "note",
        "headline"}``.
    """
    target_dict = None
    if target is not None:
        op, bound = target
        if op not in OPS:
            raise ValueError(f"figure {name!r}: target op must be one of {list(OPS)}, got {op!r}")
        target_dict = {"op": op, "value": list(bound) if op == "in" else bound}
        if met is None and value is not None and not _is_nan(value):
            met = bool(OPS[op](value, bound))
    if isinstance(exclusions, Mapping):
        exclusions = {str(k): v for k, v in exclusions.items()}
    elif exclusions is not None:
        exclusions = list(exclusions)
    return {
        "name": name,
        "value": value,
        "unit": unit,
        "target": target_dict,
        "met": met,
        "count": count,
        "exclusions": exclusions if exclusions is not None else [],
        "note": note,
        "headline": headline,
    }


def _is_nan(value: Any) -> bool:
    return isinstance(value, float) and math.isnan(value)


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(
            ["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=30, check=True
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout


def revision() -> dict[str, Any]:
    """The code the figures came from: ``{"commit", "dirty", "changed"}``.

    ``dirty`` is true when a tracked or untracked (not ignored) file outside
    ``benchmarks/results/`` differs from the commit; ``changed`` lists up to 20 of those paths.
    A checkout without git gives ``commit: None`` and ``dirty: None``.
    """
    commit = _git("rev-parse", "HEAD")
    status = _git("status", "--porcelain", "--untracked-files=normal")
    if commit is None or status is None:
        return {"commit": None, "dirty": None, "changed": []}
    changed = [
        line[3:]
        for line in status.splitlines()
        if line[3:] and not line[3:].startswith("benchmarks/results/")
    ]
    return {"commit": commit.strip(), "dirty": bool(changed), "changed": changed[:20]}


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> dict[str, Any]:
    """The machine the figures came from: cores, CPU model, platform and library versions."""
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:  # macOS has no affinity call
        usable = os.cpu_count()
    versions = {}
    for lib in _LIBRARIES:
        try:
            versions[lib] = importlib.metadata.version(lib)
        except importlib.metadata.PackageNotFoundError:
            continue
    return {
        "cores": os.cpu_count(),
        "cores_usable": usable,
        "cpu_model": _cpu_model(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "versions": versions,
    }


def _peak_rss_mb(who: int) -> float:
    peak = resource.getrusage(who).ru_maxrss
    # Linux reports kilobytes, macOS bytes.
    scale = 1.0 if sys.platform == "darwin" else 1024.0
    return round(peak * scale / 2**20, 1)


def run_record(*, quick: bool = False, started: tuple[float, Any] | None = None) -> dict[str, Any]:
    """The ``run`` block of a result: revision, date, machine, wall and CPU seconds, peak RSS.

    ``started`` is ``(time.perf_counter(), os.times())`` taken when the measurement began
    (:func:`start`); by default the time this module was imported.
    """
    wall0, cpu0 = started if started is not None else (_IMPORTED_WALL, _IMPORTED_CPU)
    # Measured before the git calls below, which are child processes too.
    wall = time.perf_counter() - wall0
    cpu1 = os.times()
    cpu = (cpu1.user - cpu0.user) + (cpu1.system - cpu0.system)
    cpu_children = (cpu1.children_user - cpu0.children_user) + (
        cpu1.children_system - cpu0.children_system
    )
    peak_self = _peak_rss_mb(resource.RUSAGE_SELF)
    peak_children = _peak_rss_mb(resource.RUSAGE_CHILDREN)
    return {
        "revision": revision(),
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "quick": quick,
        "machine": machine(),
        "wall_s": round(wall, 3),
        "cpu_s": round(cpu + cpu_children, 3),
        "cpu_children_s": round(cpu_children, 3),
        "peak_rss_mb": peak_self,
        "peak_rss_children_mb": peak_children,
        "argv": sys.argv[1:],
    }


def start() -> tuple[float, Any]:
    """Mark the start of a measurement; pass the value to :func:`write_result` as ``started``."""
    return time.perf_counter(), os.times()


def result_path(name: str, *, quick: bool = False) -> Path:
    """Where :func:`write_result` writes benchmark ``name``'s result."""
    return (QUICK_RESULTS if quick else RESULTS) / f"{name}.json"


def to_jsonable(value: Any) -> Any:
    """Arrays as lists, NumPy scalars as numbers, NaN and inf as ``None``, paths as text.

    What :func:`write_result` does to a payload; a script that prints part of one uses it too.
    """
    if hasattr(value, "as_dict"):
        return to_jsonable(value.as_dict())
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [to_jsonable(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "__array__") and not isinstance(value, str | bytes):
        import numpy as np

        arr = np.asarray(value)
        return to_jsonable(arr.item() if arr.ndim == 0 else arr.tolist())
    if hasattr(value, "item") and callable(value.item):  # NumPy scalar
        return to_jsonable(value.item())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value


def save_figure(fig: Any, path: str | os.PathLike, **savefig: Any) -> Path:
    """Save a matplotlib figure at ``path`` atomically (a temporary file renamed into place).

    ``savefig`` goes to ``fig.savefig`` (``dpi``, ``format``); the temporary file keeps the
    suffix, so the format still follows the name. Returns the path.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp{target.suffix}")
    try:
        fig.savefig(tmp, **savefig)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return target


def build_result(
    name: str,
    payload: Mapping[str, Any],
    *,
    quick: bool = False,
    figures: Iterable[Mapping[str, Any]] | None = None,
    started: tuple[float, Any] | None = None,
) -> dict[str, Any]:
    """The JSON object :func:`write_result` writes (without writing it)."""
    if not name or not name.replace("_", "").isalnum():
        raise ValueError(f"benchmark name must be letters, digits and '_', got {name!r}")
    clash = [k for k in RESERVED if k in payload and not (k == "benchmark" and payload[k] == name)]
    if clash:
        raise ValueError(f"payload of {name!r} uses the writer's keys {clash}; rename them")
    body = {k: v for k, v in payload.items() if k != "benchmark"}
    return to_jsonable(
        {
            "benchmark": name,
            "run": run_record(quick=quick, started=started),
            "figures": list(figures or []),
            **body,
        }
    )


def write_result(
    name: str,
    payload: Mapping[str, Any],
    *,
    quick: bool | None = None,
    figures: Iterable[Mapping[str, Any]] | None = None,
    started: tuple[float, Any] | None = None,
    path: str | os.PathLike | None = None,
) -> Path:
    """Write benchmark ``name``'s result with the run's provenance; return the file's path.

    Parameters
    ----------
    name
        The benchmark's name, as ``python -m benchmarks NAME`` knows it.
    payload
        The benchmark's own results (JSON-able after arrays become lists; NaN becomes ``null``).
        It must not use the keys ``run`` or ``figures``, nor ``benchmark`` for anything but
        ``name``.
    quick
        A reduced run: written under ``benchmarks/results/quick/`` (ignored by git) unless
        ``path`` says otherwise, and marked ``"quick": true``. ``None`` (the default): quick
        when the runner started the script with ``--quick`` (``TYREBAYES_BENCHMARK_QUICK=1``).
    figures
        The headline figures (:func:`figure`), which the docs' validation tables read.
    started
        :func:`start`'s value when the measurement began; default the import of this module.
    path
        Write here instead (a variant run a study keeps apart from the benchmark's result). A
        quick run's file in ``benchmarks/results/`` goes to ``benchmarks/results/quick/``.

    The file is written atomically (a temporary file renamed into place), so a killed run leaves
    the previous result whole.
    """
    if quick is None:
        quick = os.environ.get(QUICK_ENV) == "1"
    result = build_result(name, payload, quick=quick, figures=figures, started=started)
    target = Path(path) if path is not None else result_path(name, quick=quick)
    if quick and target.resolve().parent == RESULTS:
        # A quick run never replaces a measured result, whatever file the script names.
        target = QUICK_RESULTS / target.name
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(json.dumps(result, indent=1, allow_nan=False) + "\n")
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return target


def read_result(name: str, *, quick: bool = False) -> dict[str, Any]:
    """The latest result of benchmark ``name`` (``benchmarks/results/NAME.json``)."""
    return json.loads(result_path(name, quick=quick).read_text())
