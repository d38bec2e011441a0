"""Item records' helpers: the per-task memory release and peak count."""

import sys

import pytest

from tyrebayes.batch.records import peak_rss_mb, release_free_memory, reset_peak_rss


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
