"""One core per worker: a fleet worker's process, every thread of it, on one CPU.

A local fleet run has one single-threaded worker per core. The environment
(:data:`~.run._WORKER_ENV`) turns off the thread pools that OpenMP, BLAS and XLA's Eigen
kernels would start, but XLA's CPU client still sizes its own pool by the CPUs the process may
run on, and a fast tyre-set fit then kept about 1.6 cores busy for a few percent less wall time
(`benchmarks/results/fleet_run_c394029.json`: the warm loop's fits took 94 CPU s in 59 s). With
two workers on two cores those threads contend with the other worker; counted per core, they
cost a third of the fit. Pinned to one CPU before JAX starts, XLA finds one and runs the fit on
it. Linux only (``os.sched_setaffinity``); elsewhere nothing is pinned.
"""

from __future__ import annotations

import os
from pathlib import Path


def _threads() -> list[int]:
    """Thread ids of this process (the process id alone where /proc cannot say)."""
    try:
        return [int(p.name) for p in Path("/proc/self/task").iterdir()]
    except OSError:
        return [0]


def set_process_cpus(cpus: set[int]) -> None:
    """Let every thread of this process run on ``cpus`` only (those threads start later too).

    ``os.sched_setaffinity(0, ...)`` sets the calling thread's CPUs alone; a thread started later
    inherits its creator's, so every thread that exists now is set as well.
    """
    for tid in _threads():
        try:
            os.sched_setaffinity(tid, cpus)
        except OSError:  # a thread that ended meanwhile
            pass


def pin_to_one_core(index: int) -> int | None:
    """Pin this process, every thread it has, to one of the CPUs it may run on.

    Parameters
    ----------
    index : int
        Which CPU: the ``index % n``-th of the ``n`` CPUs the process may run on, in order, so
        that workers 0, 1, … of one machine take different cores.

    Returns
    -------
    int or None
        The CPU pinned to; None where the platform cannot pin.

    Examples
    --------
    >>> cpu = pin_to_one_core(0)  # doctest: +SKIP
    >>> os.sched_getaffinity(0) == {cpu}  # doctest: +SKIP
    True
    """
    if index < 0:
        raise ValueError(f"worker index: expected >= 0, got {index}")
    if not hasattr(os, "sched_setaffinity"):
        return None
    allowed = sorted(os.sched_getaffinity(0))
    cpu = allowed[index % len(allowed)]
    set_process_cpus({cpu})
    return cpu


__all__ = ["pin_to_one_core", "set_process_cpus"]
