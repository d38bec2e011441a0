"""The cluster of a fleet run: the local workers' environment."""

from __future__ import annotations

from tyrebayes.batch.cluster import _worker_env


def test_local_workers_get_one_thread_then_this_process_xla_flags(monkeypatch):
    one_thread = "--xla_cpu_multi_thread_eigen=false"
    monkeypatch.delenv("XLA_FLAGS", raising=False)
    assert _worker_env()["XLA_FLAGS"] == one_thread
    own = "--xla_dump_to=/tmp/x --xla_cpu_multi_thread_eigen=true"
    monkeypatch.setenv("XLA_FLAGS", own)
    env = _worker_env()
    assert env["XLA_FLAGS"] == f"{one_thread} {own}"
    assert env["OMP_NUM_THREADS"] == "1" and env["JAX_PLATFORMS"] == "cpu"
    # A process started with a worker's environment passes the same flags on: they are part of
    # JAX's compilation-cache key, so a repeated flag would miss every cached program.
    monkeypatch.setenv("XLA_FLAGS", env["XLA_FLAGS"])
    assert _worker_env()["XLA_FLAGS"] == env["XLA_FLAGS"]
