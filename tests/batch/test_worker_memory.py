"""A worker's memory between tasks: release, peak count, and the bound on compiled programs."""

import sys

import jax
import pytest

from tyrebayes.batch.worker_memory import (
    ProgramBudget,
    must_drop,
    peak_rss_mb,
    release_free_memory,
    reset_peak_rss,
    reuse_freed_arrays,
)


def _rss_mb() -> float:
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) / 1024.0 for line in fh if line.startswith("VmRSS:"))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc and /proc only")
def test_freed_heap_goes_back_and_the_peak_restarts_from_live_memory():
    # 200 MB of malloc'd blocks, freed but for every thousandth: the heap cannot shrink past
    # the survivors on its own, so the freed memory stays resident until it is released.
    blocks = [bytes(2000) for _ in range(100_000)]
    survivors = blocks[::1000]
    del blocks
    held = _rss_mb()
    release_free_memory()
    assert _rss_mb() < held - 100.0
    reset_peak_rss()
    assert peak_rss_mb() < held - 100.0
    assert len(survivors) == 100


def test_a_fit_drops_the_drive_programs_and_at_a_new_shape_only_the_old_shapes(monkeypatch):
    from tyrebayes.inference.tyre import shape_programs

    cleared, shapes_dropped = [], []
    monkeypatch.setattr(jax, "clear_caches", lambda: cleared.append(True))
    monkeypatch.setattr(shape_programs, "drop_shape_programs", lambda: shapes_dropped.append(1))
    budget = ProgramBudget()
    assert not budget.keep_one_fit_shape(32_768)  # a new process: nothing to drop
    budget.finish("drive", 0.0, False)  # drive tasks ran
    dropped = []
    for size in (32_768, 32_768, 16_384, 16_384, 32_768):
        dropped.append(budget.keep_one_fit_shape(size))
        budget.finish("tyre_set", 0.0, False)
    # The first fit drops the drive stage's programs; 32k -> 16k and 16k -> 32k the shapes'.
    assert dropped == [True, False, False, False, False]
    assert len(cleared) == 1 and len(shapes_dropped) == 2
    assert budget.last_fit_shape == 32_768 and budget.floor_mb is not None
    budget.finish("drive", 0.0, False)  # drive tasks again: their programs go at the next fit
    assert budget.keep_one_fit_shape(32_768) and len(cleared) == 2


def test_dropping_the_shapes_keeps_the_shared_search_and_forgets_each_shapes_core():
    from tyrebayes.inference.tyre import laplace
    from tyrebayes.inference.tyre.model import TyrePriors
    from tyrebayes.inference.tyre.predictive import _priors_key
    from tyrebayes.inference.tyre.shape_programs import drop_shape_programs

    priors = _priors_key(TyrePriors())
    for cache in (laplace._laplace_core, laplace._subset_search, laplace._posterior):
        cache.cache_clear()
    # Made, not called: nothing is compiled.
    laplace._laplace_core(priors, "magic", (8192, 1, ("dry",)), 10, 50)
    laplace._subset_search(priors, "magic", (1, ("dry",)), 50)
    drop_shape_programs()
    assert laplace._laplace_core.cache_info().currsize == 0
    assert laplace._subset_search.cache_info().currsize == 1
    assert laplace._posterior.cache_info().currsize == 1


@pytest.mark.parametrize(
    ("rss", "need", "floor", "expected"),
    [
        (1000.0, 400.0, None, False),  # fits the budget
        (1200.0, 400.0, None, True),  # over, never dropped: drop
        (1200.0, 400.0, 700.0, True),  # over, 500 MB above the floor
        (1200.0, 400.0, 1150.0, False),  # over, but a drop would free little
        (1100.0, 400.0, 700.0, True),  # 36 MB under, but not under with the need's margin
        (1070.0, 400.0, 700.0, False),  # under with the margin
    ],
)
def test_a_drop_comes_only_when_the_next_task_would_pass_the_budget(rss, need, floor, expected):
    assert must_drop(rss, need, floor, 1536.0) is expected


def _task(budget, stage, budget_mb, mb):
    """One task that holds ``mb`` MB of its own (written, so resident) at its peak."""
    start, dropped = budget.start(stage, budget_mb)
    blocks = [bytes(range(256)) * 4096 for _ in range(mb)]
    peak = budget.finish(stage, start, dropped)
    del blocks
    return start, dropped, peak


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc only")
def test_a_worker_learns_each_task_kinds_need_and_drops_its_programs_before_it_runs_over(
    monkeypatch,
):
    cleared = []
    monkeypatch.setattr(jax, "clear_caches", lambda: cleared.append(True))
    budget = ProgramBudget()
    # The first task of a stage loads its programs: its rise is not what keeping them adds to.
    start, dropped, peak = _task(budget, "drive", 1e9, 200)
    assert not dropped and peak >= start + 150.0 and "drive" not in budget.need_mb
    start, dropped, _ = _task(budget, "drive", 1e9, 200)
    assert not dropped and budget.need_mb["drive"] >= 150.0
    # A budget the next drive's need would pass: the worker drops its programs first.
    start, dropped, _ = _task(budget, "drive", start + 100.0, 10)
    assert dropped and cleared == [True]
    # Little above the floor since: no second drop; the task runs over and its record says so.
    _, dropped, _ = _task(budget, "drive", start + 100.0, 10)
    assert not dropped and cleared == [True]


_PAGE_FAULT_PROBE = """
import resource, sys
import numpy as np
from tyrebayes.batch.worker_memory import reuse_freed_arrays
if sys.argv[1] == "1":
    assert reuse_freed_arrays()
x = np.ones(400_000)  # 3.2 MB: one hour of a 100 Hz channel is 2.9 MB
for _ in range(3):
    y = x * 2.0
    del y
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(50):
    y = x * 2.0
    del y
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc only")
def test_fixed_malloc_thresholds_are_repaired_so_large_arrays_stop_page_faulting():
    import os
    import subprocess

    def faults(env: dict, repair: bool) -> int:
        done = subprocess.run(
            [sys.executable, "-c", _PAGE_FAULT_PROBE, "1" if repair else "0"],
            env={**os.environ, **env},
            capture_output=True,
            text=True,
            check=True,
        )
        return int(done.stdout.strip().splitlines()[-1])

    # dask's nannies start workers with this; glibc then maps every large array afresh.
    fixed = {"MALLOC_TRIM_THRESHOLD_": "65536"}
    assert faults(fixed, repair=False) > 50 * 500  # ~780 pages per 3.2 MB array
    assert faults(fixed, repair=True) < 500
    # Without such a variable glibc's own rule reuses the heap, and nothing is changed.
    unfixed = subprocess.run(
        [sys.executable, "-c", _PAGE_FAULT_PROBE, "0"],
        env={k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")},
        capture_output=True,
        text=True,
        check=True,
    )
    assert int(unfixed.stdout.strip().splitlines()[-1]) < 500


def test_thresholds_are_left_alone_where_nothing_fixed_them():
    assert reuse_freed_arrays({}) is False
    assert reuse_freed_arrays({"PATH": "/usr/bin"}) is False
