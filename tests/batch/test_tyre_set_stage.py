"""The tyre-set stage's shape handling (its fits run end to end in ``test_run.py``)."""

from __future__ import annotations

import jax

from tyrebayes.batch import tyre_set_stage
from tyrebayes.batch.tyre_set_stage import _keep_one_shape, pad_size


def test_pad_sizes_are_powers_of_two_from_256():
    assert [pad_size(n) for n in (1, 256, 257, 10_136, 16_384, 16_385)] == [
        256, 256, 512, 16_384, 16_384, 32_768
    ]  # fmt: skip


def test_compiled_programs_are_dropped_at_the_first_fit_and_when_the_shape_changes(monkeypatch):
    cleared = []
    monkeypatch.setattr(jax, "clear_caches", lambda: cleared.append(True))
    monkeypatch.setattr(tyre_set_stage, "_LAST_SHAPE", [])
    for size in (32_768, 32_768, 16_384, 16_384, 16_384, 32_768):
        _keep_one_shape(size)
    # The first fit drops the drive stage's programs; then 32k -> 16k and 16k -> 32k.
    assert len(cleared) == 3
    assert tyre_set_stage._LAST_SHAPE == [32_768]
