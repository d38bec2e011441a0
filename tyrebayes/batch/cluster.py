"""The dask cluster a fleet run's tasks run on: a new ``LocalCluster`` or one at an address.

:func:`dask_client` gives the client; the local workers get one task thread each, a memory limit
that is a hard stop only (no spilling, no pausing), one-thread numerical libraries and the
package imported before their first task.
"""

from __future__ import annotations

import contextlib
import os

from .. import _interrupts
from .._errors import BadInputError

#: Memory limit of each local worker, the hard stop above the tasks' budget
#: (``RunSettings.memory_budget_mb``): without the budget a fast fit of a set of four 10-60 min
#: drives held up to 1.8 GB at its peak and a drive task up to 1.9 GB (the ``fleet_run``
#: benchmark at full size); the limit leaves room above that for a larger set.
DEFAULT_MEMORY_LIMIT = "4GiB"

# The tasks keep no data in the workers (they write files and return small records), so dask's
# spilling and pausing only get in the way: memory that JAX and the allocator keep after a fit
# does not come back, and a paused single worker never resumes. The limit stays as the nanny's
# hard stop (a worker over 95 % is restarted and its task recorded as failed).
# The nannies' default MALLOC_TRIM_THRESHOLD_ is unset (None removes it): it turns off glibc's
# dynamic mmap threshold, and every large array then page-faults afresh
# (:func:`.worker_memory.reuse_freed_arrays`, which repairs it on other clusters' workers). The
# freed heap still goes back after each task (:func:`.worker_memory.release_free_memory`).
_WORKER_MEMORY_CONFIG = {
    "distributed.worker.memory.target": False,
    "distributed.worker.memory.spill": False,
    "distributed.worker.memory.pause": False,
    "distributed.worker.memory.terminate": 0.95,
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
}

# One task thread per worker, and OpenMP, BLAS and XLA's Eigen kernels without thread pools of
# their own (XLA's CPU runtime still runs independent parts of a program in parallel; pinning a
# worker to one core to stop that cost more wall time than it saved: README, fleet runs).
_WORKER_ENV = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "JAX_ENABLE_X64": "1",
    "JAX_PLATFORMS": "cpu",
}
_WORKER_XLA_FLAGS = "--xla_cpu_multi_thread_eigen=false"


def _worker_env() -> dict[str, str]:
    """The local workers' environment: :data:`_WORKER_ENV`, and XLA_FLAGS that start with the
    one-thread flag and go on with this process's own, so that a dump folder or a code generator
    chosen for the run reaches the workers too (and wins where both name a flag: XLA reads the
    last). Idempotent: flags that already start with the one-thread flag are kept as they are,
    so that a process started with a worker's environment gives its workers the same flags (they
    are part of JAX's compilation-cache key, and a repeated flag would change it)."""
    own = os.environ.get("XLA_FLAGS", "").strip()
    if own.split()[:1] == [_WORKER_XLA_FLAGS]:
        return {**_WORKER_ENV, "XLA_FLAGS": own}
    return {**_WORKER_ENV, "XLA_FLAGS": f"{_WORKER_XLA_FLAGS} {own}".strip()}


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None, memory_limit=None):
    """A dask ``Client``: on the cluster at ``scheduler``, or on a new ``LocalCluster``.

    The local cluster has ``workers`` processes (default: one per core), each with one task thread
    and ``memory_limit`` (default :data:`DEFAULT_MEMORY_LIMIT`). With an address the cluster's
    own workers run the tasks (dask-jobqueue, Kubernetes, cloud: the same code). Either way the
    workers import the package before their first task (:class:`.worker_plugin.ImportTasks`).
    The local workers ignore SIGINT (:class:`.worker_plugin.IgnoreCtrlC`): Ctrl-C stops the
    client, which closes them.

    Raises
    ------
    BadInputError
        No scheduler answers at ``scheduler`` (within dask's connect timeout,
        ``distributed.comm.timeouts.connect``), or its workers cannot import the package.
    """
    import dask
    from distributed import Client, LocalCluster

    from .worker_plugin import IgnoreCtrlC, ImportTasks

    if scheduler:
        try:
            client = Client(scheduler)
        except (OSError, ValueError) as err:  # unreachable (a timeout is an OSError), malformed
            raise BadInputError(
                f"scheduler: expected a reachable dask scheduler, got {scheduler!r} "
                f"({_first_line(err)})"
            ) from None
        with client:
            _register_import_tasks(client, scheduler)
            yield client
        return
    n = workers or os.cpu_count() or 1
    with (
        dask.config.set(_WORKER_MEMORY_CONFIG),
        LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            memory_limit=memory_limit or DEFAULT_MEMORY_LIMIT,
            dashboard_address=":0",  # any free port: two runs on one machine must not clash
            env=_worker_env(),
        ) as cluster,
        Client(cluster) as client,
    ):
        client.register_plugin(IgnoreCtrlC())
        client.register_plugin(ImportTasks())
        try:
            yield client
        except BaseException:
            if _interrupts.pending() is not None:
                _quiet_workers(client)
            raise


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


def _register_import_tasks(client, scheduler: str) -> None:
    """:class:`.worker_plugin.ImportTasks` on a cluster at an address, whose workers were
    started elsewhere: one that cannot import the package (another environment) fails here, in
    one line, not in every task."""
    from .worker_plugin import ImportTasks

    try:
        client.register_plugin(ImportTasks())
    except Exception as err:  # noqa: BLE001 -- the worker's own error, whatever it is
        raise BadInputError(
            f"scheduler {scheduler}: expected workers that import tyrebayes (the same "
            f"environment as this client), got {type(err).__name__}: {_first_line(err)}"
        ) from None


def _quiet_workers(client) -> None:
    """Before a local cluster closes on a signal: its workers' warnings about the tasks the
    closing cancels would print around the command's one line."""

    def quiet() -> None:
        import logging

        logging.getLogger("distributed").setLevel(logging.CRITICAL + 1)

    with contextlib.suppress(Exception):
        client.run(quiet, on_error="ignore")
