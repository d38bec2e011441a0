"""The tyre-set stage's shape handling (its fits run end to end in ``test_run.py``)."""

from __future__ import annotations

from tyrebayes.batch.tyre_set_stage import pad_size


def test_pad_sizes_are_four_per_octave_from_256():
    assert [pad_size(n) for n in (1, 256, 257, 10_136, 16_384, 16_385, 20_481)] == [
        256, 256, 320, 10_240, 16_384, 20_480, 24_576
    ]  # fmt: skip


def test_load_sensitivity_refits_tyre_sets_but_keeps_the_drives():
    """The load sensitivity changes the tyre-set fit, not the windows: a rerun with it refits
    every set (its settings differ) and skips every drive (theirs do not)."""
    from tyrebayes.batch import RunSettings

    plain, loaded = RunSettings(), RunSettings(load_sensitivity=True)
    assert plain.drive_settings() == loaded.drive_settings()
    assert plain.tyre_set_settings() != loaded.tyre_set_settings()
    assert loaded.tyre_set_settings()["load_sensitivity"] is True


def test_a_set_without_drives_is_a_failed_record_and_skipped_on_the_rerun(tmp_path):
    from tyrebayes.batch import RunSettings, fit_tyre_set
    from tyrebayes.batch.tyre_set_stage import TYRE_SETS_DIR

    (tmp_path / TYRE_SETS_DIR).mkdir()
    record = fit_tyre_set("set 1", "winter", [], str(tmp_path), RunSettings())
    assert record["status"] == "failed" and record["outputs"] == []
    assert record["reason"] == "no drive of this tyre set was processed"
    assert not record["skipped"] and record["drives"] == []
    assert isinstance(record["programs_dropped"], bool) and record["seconds"] >= 0.0
    again = fit_tyre_set("set 1", "winter", [], str(tmp_path), RunSettings())
    assert again["skipped"] and again["status"] == "failed"
    assert again["input_hash"] == record["input_hash"]
