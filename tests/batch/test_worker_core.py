"""Pinning a worker to one core (tyrebayes/batch/worker_core.py)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

from tyrebayes.batch.worker_core import pin_to_one_core

pytestmark = pytest.mark.skipif(
    not hasattr(os, "sched_setaffinity"), reason="pinning needs os.sched_setaffinity (Linux)"
)

# In a child process: pinning the test process would pin every later test.
_CHILD = textwrap.dedent(
    """
    import os, threading, json
    from pathlib import Path
    from tyrebayes.batch.worker_core import pin_to_one_core

    allowed = sorted(os.sched_getaffinity(0))
    stop = threading.Event()
    before = threading.Thread(target=stop.wait)  # a thread that exists before the pin
    before.start()
    cpu = pin_to_one_core({index})
    after = []
    later = threading.Thread(target=lambda: after.append(sorted(os.sched_getaffinity(0))))
    later.start()
    later.join()
    threads = {{
        int(t.name): sorted(os.sched_getaffinity(int(t.name)))
        for t in Path("/proc/self/task").iterdir()
    }}
    stop.set()
    before.join()
    print(json.dumps({{"allowed": allowed, "cpu": cpu, "threads": list(threads.values()),
                      "later": after[0]}}))
    """
)


@pytest.mark.parametrize("index", [0, 1, 5])
def test_every_thread_is_pinned_to_the_index_th_cpu(index):
    import json

    out = subprocess.run(
        [sys.executable, "-c", _CHILD.format(index=index)],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    got = json.loads(out.stdout.strip().splitlines()[-1])
    allowed = got["allowed"]
    assert got["cpu"] == allowed[index % len(allowed)]
    assert len(got["threads"]) >= 2  # the main thread and the one started before the pin
    assert all(cpus == [got["cpu"]] for cpus in got["threads"])
    assert got["later"] == [got["cpu"]]  # threads started after inherit the pin


def test_negative_index_is_a_one_line_error():
    with pytest.raises(ValueError, match="worker index: expected >= 0, got -1"):
        pin_to_one_core(-1)
