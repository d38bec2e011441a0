"""The worker plugins of a fleet run: workers import the package when they join, not in a task;
a local cluster's workers leave Ctrl-C to their client.

Without it a worker's first task pays the imports of the package, JAX and NumPyro (seconds),
on every worker of every run; with it they are paid while the cluster starts, and a worker that
joins a running cluster later pays them before it takes a task. It also lets the heap serve
large arrays again where the worker was started with glibc's thresholds fixed
(:func:`~.worker_memory.reuse_freed_arrays`: a cluster's nannies do so by default).
"""

from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin


class ImportTasks(WorkerPlugin):
    """Imports the modules the fleet run's tasks use (registered by ``run.dask_client``)."""

    name = "tyrebayes-import-tasks"

    def setup(self, worker) -> None:
        from .worker_memory import reuse_freed_arrays

        reuse_freed_arrays()
        import tyrebayes.batch.drive_stage  # noqa: F401
        import tyrebayes.batch.tyre_set_stage  # noqa: F401
        import tyrebayes.inference.tyre.fit  # noqa: F401


class IgnoreCtrlC(WorkerPlugin):
    """A local worker ignores SIGINT (registered by ``run.dask_client`` for its own cluster only).

    Ctrl-C in a terminal reaches its whole process group, the local workers too: each then shut
    itself down under its task, and the task, its fit torn down, failed and was recorded as
    failed for good. The client gets the signal too and closes the cluster, which stops them.
    Not for a cluster at an address: its workers are not this command's to change.
    """

    name = "tyrebayes-ignore-ctrl-c"

    def setup(self, worker) -> None:
        from .._interrupts import ignore_in_child

        ignore_in_child()


__all__ = ["IgnoreCtrlC", "ImportTasks"]
