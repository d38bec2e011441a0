"""The worker plugin of a fleet run: workers set up when they join, not in a task.

Without it a worker's first task pays the imports of the package, JAX and NumPyro (seconds),
on every worker of every run; with it they are paid while the cluster starts, and a worker that
joins a running cluster later pays them before it takes a task. A local cluster's workers are
also pinned to one core each (:mod:`.worker_core`), before anything starts JAX.
"""

from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin


class ImportTasks(WorkerPlugin):
    """Imports the modules the fleet run's tasks use (registered by ``run.dask_client``).

    Parameters
    ----------
    pin : bool
        Pin each worker to one core first, worker ``k`` (its name) to the ``k``-th CPU: for
        the workers of a ``LocalCluster``, one per core. A worker whose name is not a number,
        and the workers of another cluster, are left as their cluster placed them.
    """

    name = "tyrebayes-import-tasks"

    def __init__(self, pin: bool = False):
        self.pin = pin

    def setup(self, worker) -> None:
        index = _worker_index(worker)
        if self.pin and index is not None:
            from .worker_core import pin_to_one_core

            pin_to_one_core(index)
        import tyrebayes.batch.drive_stage  # noqa: F401
        import tyrebayes.batch.tyre_set_stage  # noqa: F401
        import tyrebayes.inference.tyre.fit  # noqa: F401


def _worker_index(worker) -> int | None:
    """A local worker's number (``LocalCluster`` names its workers 0, 1, …), else None."""
    try:
        return int(worker.name)
    except (TypeError, ValueError):
        return None


__all__ = ["ImportTasks"]
