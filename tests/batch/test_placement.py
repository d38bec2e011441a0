import numpy as np
import pytest

from tyrebayes.batch.placement import place_sets
from tyrebayes.batch.tyre_set_stage import pad_size


def _fleet(n_sets: int, seed: int) -> dict[str, int]:
    """Padded sizes of sets of 4 drives of 10-60 min (2 slip windows a second of driving)."""
    rng = np.random.default_rng(seed)
    minutes = rng.uniform(10, 60, size=(n_sets, 4)).sum(axis=1)
    return {f"set{k:03d}": pad_size(int(m * 60 * 2)) for k, m in enumerate(minutes)}


@pytest.mark.parametrize("n_workers", [1, 2, 3, 8])
def test_each_worker_gets_few_shapes_and_a_fair_share(n_workers):
    sizes = _fleet(50, seed=n_workers)
    slots = {f"tcp://w{k}": 1 for k in range(n_workers)}
    where = place_sets(sizes, slots)
    assert set(where) == set(sizes) and set(where.values()) <= set(slots)
    # (worker, shape) pairs: each is one load of a shape's programs.
    loads = {(where[s], sizes[s]) for s in sizes}
    n_shapes = len(set(sizes.values()))
    assert len(loads) <= n_shapes + n_workers - 1
    # Balance: no worker is more than one set's work from its share.
    work = {w: sum(sizes[s] for s in sizes if where[s] == w) for w in slots}
    share = sum(sizes.values()) / n_workers
    assert max(abs(v - share) for v in work.values()) <= max(sizes.values())


def test_sets_run_largest_first_in_contiguous_runs():
    sizes = _fleet(40, seed=5)
    where = place_sets(sizes, {"a": 1, "b": 1})
    order = sorted(sizes, key=lambda s: (-sizes[s], s))
    runs = [where[s] for s in order]
    changes = sum(x != y for x, y in zip(runs, runs[1:], strict=False))
    assert changes == 1  # one worker takes the larger shapes, the other the smaller


def test_threads_weigh_a_workers_share():
    sizes = {f"s{k}": 1024 for k in range(12)}
    where = place_sets(sizes, {"big": 2, "small": 1})
    assert sum(w == "big" for w in where.values()) == 8


def test_a_later_release_goes_where_its_shape_is_loaded_and_balances_the_rest():
    first = place_sets({"a": 4096, "b": 2048}, {"w1": 1, "w2": 1})
    assert first == {"a": "w1", "b": "w2"}
    placed = {"w1": 8192.0, "w2": 2048.0}
    shapes = {4096: "w1", 2048: "w2"}
    later = place_sets({"c": 2048, "d": 1024}, {"w1": 1, "w2": 1}, placed, shapes)
    assert later["c"] == "w2"  # its shape's programs are there
    assert later["d"] == "w2"  # w2 has less work: 2048 + 2048 against 8192
    # A worker that has left: its shape goes where the balance says.
    gone = place_sets({"e": 4096}, {"w2": 1, "w3": 1}, {"w2": 5120.0}, shapes)
    assert gone == {"e": "w3"}


def test_no_workers_is_an_error():
    with pytest.raises(ValueError, match="expected at least one worker, got none"):
        place_sets({"a": 256}, {})
