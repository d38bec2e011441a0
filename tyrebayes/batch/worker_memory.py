"""What a fleet worker keeps between tasks: its memory counts and a bound on its compiled programs.

A worker is one long-lived process that runs drive tasks and tyre-set fits in turn. Two things
stay resident after a task and count towards every later task's peak:

* heap that glibc keeps after the task freed it (:func:`release_free_memory` gives it back);
* the programs JAX compiled: a fit's programs of one padded shape, those its shapes share (the
  search on a subset of the windows), and each padded drive length's force-density EM and
  temperature scan. Keeping them is what makes the next task of the same shape fast (a dropped
  program is reloaded from the shared cache), so they are dropped only when keeping them would
  take the next task past the worker's memory budget (:class:`ProgramBudget`); a fit drops the
  drive stage's programs, and the per-shape programs of the fits before it when its padded
  shape changes (:meth:`ProgramBudget.keep_one_fit_shape`).
"""

from __future__ import annotations

import dataclasses

from ..internal.heap import release_free_memory

#: A drop is worth its reloads only when the programs hold at least this much [MB] above what
#: the process held right after its last drop (its floor): below, nothing much would be freed.
MIN_DROP_MB = 100.0
#: A task is taken to need this multiple of the largest rise seen in its stage. The largest of n
#: rises seen is passed by the next task's in about 1 case of n + 1 (a longer drive, a padded
#: shape not met before); without the margin the ``fleet_run`` benchmark had workers a few MB
#: over their budget.
NEED_MARGIN = 1.15


def _status_mb(field: str) -> float | None:
    """A memory field of ``/proc/self/status`` (``VmRSS``, ``VmHWM``) [MB]; None without it."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(f"{field}:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def rss_mb() -> float:
    """This process's resident memory now [MB] (VmRSS on Linux; its peak elsewhere)."""
    now = _status_mb("VmRSS")
    return peak_rss_mb() if now is None else now


def peak_rss_mb() -> float:
    """This process's peak resident memory [MB] (VmHWM on Linux).

    ``getrusage``'s ``ru_maxrss`` survives ``execve`` on Linux, so a worker spawned by a large
    process would report its parent's peak; the kernel's VmHWM is the process's own.
    """
    peak = _status_mb("VmHWM")
    if peak is not None:
        return peak
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


#: glibc's ``mallopt`` parameters (malloc.h) and the values set where a worker's thresholds are
#: fixed: 32 MiB is the ceiling of glibc's own dynamic mmap threshold, and twice it the trim
#: threshold that rule pairs with it.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024
_FIXED_BY = (
    "MALLOC_TRIM_THRESHOLD_",
    "MALLOC_MMAP_THRESHOLD_",
    "MALLOC_TOP_PAD_",
    "MALLOC_MMAP_MAX_",
)


def reuse_freed_arrays(environ=None) -> bool:
    """Let the heap serve large arrays again in a process started with glibc's thresholds fixed.

    glibc maps each allocation above its mmap threshold freshly from the kernel and unmaps it
    when freed, so every use of it page-faults anew; its threshold normally rises to the size
    of the arrays a process frees (up to 32 MiB), after which they come from the heap. Setting
    any of ``MALLOC_TRIM_THRESHOLD_``, ``MALLOC_MMAP_THRESHOLD_``, ``MALLOC_TOP_PAD_`` or
    ``MALLOC_MMAP_MAX_`` turns that rule off, and dask's nannies set the first (64 kB) in every
    worker by default: there each of the drive stage's one-hour arrays (2.9 MB) cost page faults,
    and the stage ran 2.3 times slower than in a plain process (16 simulated drives, 9.4
    drive-hours: 1.15 against 0.49 CPU s per drive-hour, one-off). In such a process this sets
    the thresholds that rule would reach (:data:`_MMAP_THRESHOLD_BYTES`, twice it for trimming);
    the heap freed between tasks still goes back (:func:`release_free_memory`). Returns whether
    it did (no: no such variable, or no glibc).
    """
    import ctypes
    import os

    environ = os.environ if environ is None else environ
    if not any(name in environ for name in _FIXED_BY):
        return False
    try:
        libc = ctypes.CDLL("libc.so.6")
        return bool(
            libc.mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD_BYTES)
            and libc.mallopt(_M_TRIM_THRESHOLD, 2 * _MMAP_THRESHOLD_BYTES)
        )
    except (OSError, AttributeError):
        return False


def reset_peak_rss() -> None:
    """Start a new peak-memory count for this process (Linux: ``5`` to ``/proc/self/clear_refs``).

    A worker runs many tasks; resetting at the start of each makes its record's
    ``peak_rss_mb`` that task's own peak, on top of the memory still in use (free memory the
    allocator kept is released first: :func:`release_free_memory`). Where the file cannot be
    written the count goes on.
    """
    release_free_memory()
    _restart_peak_count()


def _restart_peak_count() -> None:
    """:func:`reset_peak_rss` without its release of free heap (for a caller that just did)."""
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        pass


def drop_compiled_programs() -> None:
    """Drop every program JAX compiled or traced in this process, and the heap they held."""
    import jax

    jax.clear_caches()
    release_free_memory()


def must_drop(rss: float, need: float, floor: float | None, budget: float) -> bool:
    """Whether to drop the compiled programs before a task (all in MB).

    Drop when the memory held now (``rss``) plus the most a task of this stage has needed above
    its start (``need``), times :data:`NEED_MARGIN`, would pass ``budget``, unless the process
    holds less than :data:`MIN_DROP_MB` above its ``floor`` (what it held right after its last
    drop; None: no drop yet): then a drop would cost reloads and free little, and the task runs
    over budget, which its record shows.

    Examples
    --------
    >>> must_drop(1200.0, 400.0, 700.0, 1536.0), must_drop(1000.0, 400.0, 700.0, 1536.0)
    (True, False)
    >>> must_drop(1100.0, 400.0, 700.0, 1536.0)  # 1,500 MB, but not with the margin
    True
    >>> must_drop(1200.0, 400.0, 1150.0, 1536.0)
    False
    """
    if rss + NEED_MARGIN * need <= budget:
        return False
    return floor is None or rss - floor >= MIN_DROP_MB


@dataclasses.dataclass
class ProgramBudget:
    """A worker's bound on what it carries into a task: one instance per process.

    Attributes
    ----------
    need_mb : dict
        Per stage (``"drive"``, ``"tyre_set"``), the largest rise of a task's peak above the
        memory it started with [MB], over this process's tasks that found the programs of
        earlier ones kept: the rise that keeping them adds to. A task that started by dropping
        them, or the first of its stage in the process, reloads its programs and rises more;
        counting those would make every later task drop, and reload, again.
    floor_mb : float or None
        Resident memory right after this process's last drop [MB].
    last_fit_shape : int or None
        Padded number of windows of the last tyre-set fit since the last drop.
    dirty : bool
        Whether a task ran since the last drop (there are programs to drop).
    seen_stages : set of str
        The stages this process has run a task of.
    last_stage : str or None
        The stage of the last task this process finished.
    """

    need_mb: dict[str, float] = dataclasses.field(default_factory=dict)
    floor_mb: float | None = None
    last_fit_shape: int | None = None
    dirty: bool = False
    seen_stages: set[str] = dataclasses.field(default_factory=set)
    last_stage: str | None = None

    def start(self, stage: str, budget_mb: float) -> tuple[float, bool]:
        """Before a task: release free heap, drop the programs if :func:`must_drop` says so,
        and start the task's peak count. Returns the resident memory the task starts with [MB]
        and whether the programs were dropped."""
        release_free_memory()
        need = self.need_mb.get(stage, 0.0)
        dropped = self.dirty and must_drop(rss_mb(), need, self.floor_mb, budget_mb)
        if dropped:
            self._drop()
        # The peak count restarts from what is resident now, so a task's peak is never below
        # its start unless the task itself drops programs (a fit at a new shape). The free heap
        # went back above (and in a drop): another release would only walk the heap again.
        _restart_peak_count()
        return rss_mb(), dropped

    def finish(self, stage: str, start_mb: float, dropped: bool) -> float:
        """After a task: its peak [MB], which also updates what a task of its stage needs
        (``dropped``: whether the task started by dropping the programs, or dropped them)."""
        peak = peak_rss_mb()
        if not dropped and stage in self.seen_stages:
            self.need_mb[stage] = max(self.need_mb.get(stage, 0.0), peak - start_mb)
        self.seen_stages.add(stage)
        self.last_stage = stage
        self.dirty = True
        return peak

    def keep_one_fit_shape(self, size: int) -> bool:
        """Before a fit of ``size`` padded windows: drop what it will not use. True if every
        program was dropped.

        The first fit after drive tasks (or in a process) drops every program: the per-drive
        stage's, which a fit does not use. A fit whose padded shape differs from the last fit's
        drops the per-shape programs of the fits before it
        (:func:`tyrebayes.inference.tyre.shape_programs.drop_shape_programs`; hundreds of MB
        over a few shapes) and keeps those every shape shares. The run gives the sets with the
        largest shape the highest priority (:func:`~.run.fleet_run`), so a worker meets each
        shape about once.
        """
        if self.dirty and self.last_stage != "tyre_set":
            self._drop()
            self.last_fit_shape = size
            return True
        if self.last_fit_shape is not None and self.last_fit_shape != size:
            from ..inference.tyre.shape_programs import drop_shape_programs

            drop_shape_programs()
        self.last_fit_shape = size
        return False

    def _drop(self) -> None:
        drop_compiled_programs()
        self.floor_mb = rss_mb()
        self.last_fit_shape = None
        self.dirty = False


#: This process's budget state (a dask worker is one process running one task at a time).
WORKER = ProgramBudget()


__all__ = [
    "MIN_DROP_MB",
    "NEED_MARGIN",
    "WORKER",
    "ProgramBudget",
    "drop_compiled_programs",
    "must_drop",
    "peak_rss_mb",
    "release_free_memory",
    "reset_peak_rss",
    "reuse_freed_arrays",
    "rss_mb",
]
