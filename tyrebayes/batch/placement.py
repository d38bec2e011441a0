"""Which worker fits which tyre set: each padded fit shape on as few workers as balance allows.

A worker's first fit of a padded shape loads that shape's own compiled programs, and a worker
keeps one shape's at a time (:meth:`.worker_memory.ProgramBudget.keep_one_fit_shape`): in the
``fleet_run`` benchmark a warm loop's first fit of a shape takes two to three times a fit whose
shape is loaded (``tyre_set_fit_seconds``). Sent to whichever worker is free, the ready sets of
every shape reach every worker, and each worker loads nearly every shape (2 workers loaded 9
shapes where one worker loaded 5).

:func:`place_sets` splits the sets, in the order they run (largest padded shape first), into
one contiguous run per worker of about equal work (padded windows summed: a fast fit's cost
grows with its padded size). A worker then meets only the shapes of its own run, so W workers
load at most S + W − 1 shapes for S shapes, not up to S × W. The placement is a preference
(:func:`~.run.fleet_run` submits with loose restrictions): a worker that falls idle still takes
another's queued sets, and a lost worker's sets run elsewhere.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np


def place_sets(
    sizes: Mapping[str, int],
    slots: Mapping[str, int],
    placed: Mapping[str, float] | None = None,
    shape_worker: Mapping[int, str] | None = None,
) -> dict[str, str]:
    """The worker each ready set is sent to.

    Parameters
    ----------
    sizes : mapping
        Set id → its fit's padded number of windows, in any order.
    slots : mapping
        Worker address → its task threads (a worker of 2 threads takes twice the share).
    placed : mapping, optional
        Worker → padded windows already sent to it this run (earlier releases).
    shape_worker : mapping, optional
        Padded size → the worker that last received sets of that size: a set of a size
        already placed goes there, the worker that has its programs.

    Returns
    -------
    dict
        Set id → worker address, for every set in ``sizes``.

    Examples
    --------
    Two workers, three shapes: the largest shape to one worker, the other two to the other.

    >>> place_sets({"a": 4096, "b": 4096, "c": 2048, "d": 2048, "e": 1024, "f": 1024,
    ...             "g": 1024, "h": 1024}, {"w1": 1, "w2": 1})
    {'a': 'w1', 'b': 'w1', 'c': 'w2', 'd': 'w2', 'e': 'w2', 'f': 'w2', 'g': 'w2', 'h': 'w2'}
    """
    if not slots:
        raise ValueError("place_sets: expected at least one worker, got none")
    placed = dict(placed or {})
    # A worker that has left the cluster since holds no programs.
    shape_worker = {k: w for k, w in (shape_worker or {}).items() if w in slots}
    workers = sorted(slots, key=lambda w: (placed.get(w, 0.0) / slots[w], w))
    order = sorted(sizes, key=lambda s: (-sizes[s], s))
    known = [s for s in order if sizes[s] in shape_worker]
    new = [s for s in order if sizes[s] not in shape_worker]
    placement = {s: shape_worker[sizes[s]] for s in known}
    for s in known:
        placed[placement[s]] = placed.get(placement[s], 0.0) + sizes[s]
    # The new sets' work, with what the workers already hold, shared by threads: each worker
    # takes up to its share, the next run of new sets (least loaded first). A set goes to the
    # worker whose stretch of the running total holds its middle, so no error accumulates.
    total = sum(placed.get(w, 0.0) for w in slots) + sum(sizes[s] for s in new)
    capacity = [
        max(0.0, total * slots[w] / sum(slots.values()) - placed.get(w, 0.0)) for w in workers
    ]
    ends = np.cumsum(capacity)
    running = 0.0
    for s in new:
        k = min(int(np.searchsorted(ends, running + sizes[s] / 2, side="right")), len(workers) - 1)
        placement[s] = workers[k]
        running += sizes[s]
    return {s: placement[s] for s in sizes}


__all__ = ["place_sets"]
