"""comma raw_can logs: the folder of four arrays, its .npz form, and what a bad one says."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tyrebayes import BadInputError
from tyrebayes.cli import main
from tyrebayes.streams.can import read_can_log, read_comma_raw_can, read_frames
from tyrebayes.streams.can.comma import ARRAYS

FIXTURE = Path(__file__).resolve().parents[1] / "data" / "comma2k19_rav4" / "raw_can.npz"
PROFILE_IDS = {0xAA, 0x24, 0x25, 0xB4}


@pytest.fixture(scope="module")
def arrays() -> dict[str, np.ndarray]:
    with np.load(FIXTURE) as archive:
        return {name: archive[name] for name in ARRAYS}


def _folder(arrays, path: Path, suffix: str = "") -> Path:
    """The arrays as comma2k19 stores them: ``np.save`` files without an extension."""
    path.mkdir()
    for name, a in arrays.items():
        with open(path / f"{name}{suffix}", "wb") as fh:
            np.save(fh, a)
    return path


@pytest.mark.parametrize("suffix", ["", ".npy"])
def test_folder_and_archive_read_alike(arrays, tmp_path, suffix):
    folder = _folder(arrays, tmp_path / "raw_can", suffix)
    a, counts_a = read_frames(folder, ids=PROFILE_IDS)
    b, counts_b = read_frames(FIXTURE, ids=PROFILE_IDS)
    assert counts_a == counts_b
    assert counts_a.frames == arrays["t"].size and counts_a.kept == 17_409
    for field in ("time_s", "arbitration_id", "data", "length", "bus"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert a.exact_length is False and a.bus_names == ("0",)


def test_payloads_and_lengths(arrays):
    frames, _ = read_comma_raw_can(FIXTURE, ids={0x24})
    rows = np.flatnonzero(arrays["address"] == 0x24)
    payloads = arrays["data"][rows]  # NumPy drops each payload's trailing zero bytes
    assert frames.data.shape == (rows.size, 8)
    assert [bytes(frames.data[k, : frames.length[k]]) for k in range(rows.size)] == list(payloads)
    assert set(frames.length.tolist()) <= {7, 8}  # 0x24 is 8 bytes long; some end in zero


def test_bus_filter_names_the_panda_source(arrays):
    _, on_bus_0 = read_comma_raw_can(FIXTURE, ids=PROFILE_IDS, bus="0")
    assert on_bus_0.kept == 17_409 and on_bus_0.other_bus == 0
    frames, on_bus_1 = read_comma_raw_can(FIXTURE, ids=PROFILE_IDS, bus="1")
    assert on_bus_1.kept == 0 and on_bus_1.other_bus == 17_409 and frames.time_s.size == 0
    everything, counts = read_comma_raw_can(FIXTURE)
    assert counts.buses == ("0", "1", "128", "129")
    assert set(everything.bus_names) == set(counts.buses)
    np.testing.assert_array_equal(
        np.array(everything.bus_names, dtype=np.int64)[everything.bus], arrays["src"]
    )


def test_a_longer_payload_than_the_dbc_says_is_refused(profile, tmp_path):
    # Without the DLC in the log only bytes beyond the DBC's length can show a mismatch.
    shipped = profile.dbc_path().read_text()
    short = tmp_path / "short.dbc"
    short.write_text(shipped.replace("BO_ 36 KINEMATICS: 8", "BO_ 36 KINEMATICS: 6"))
    with pytest.raises(BadInputError, match=r"KINEMATICS .* 6 bytes in the DBC, got .* at least"):
        read_can_log(FIXTURE, profile, dbc=short)


def test_a_folder_missing_an_array(arrays, tmp_path, capsys):
    folder = _folder({k: v for k, v in arrays.items() if k != "src"}, tmp_path / "raw_can")
    with pytest.raises(BadInputError) as info:
        read_frames(folder)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(
        "CAN log raw_can: expected a comma raw_can folder with arrays address, data, src, t, "
        "got no 'src'"
    )
    out = tmp_path / "s.parquet"
    argv = ["convert", str(folder), "--profile", "toyota_rav4_2017", "--out", str(out)]
    assert main(argv) == 2
    _, err = capsys.readouterr()
    assert len(err.strip().splitlines()) == 1 and "got no 'src'" in err


def test_convert_command_takes_the_folder(arrays, tmp_path, capsys):
    folder = _folder(arrays, tmp_path / "raw_can")
    out = tmp_path / "s.parquet"
    argv = ["convert", str(folder), "--profile", "toyota_rav4_2017", "--out", str(out), "--json"]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["frames_read"] == arrays["t"].size and out.is_file()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"t": np.zeros(3)}, "expected four 1-d arrays of one length"),
        ({"data": np.zeros(135_468, dtype=np.int64)}, r"expected 'data' as fixed-width bytes"),
        ({"address": np.zeros(135_468)}, "expected integer 'address'"),
        ({"t": np.full(135_468, np.nan)}, "expected finite float times 't'"),
    ],
)
def test_arrays_of_the_wrong_kind(arrays, tmp_path, change, match):
    path = tmp_path / "bad.npz"
    np.savez(path, **{**arrays, **change})
    with pytest.raises(BadInputError, match=match):
        read_frames(path)


def test_archive_missing_an_array_or_corrupt(arrays, tmp_path):
    partial = tmp_path / "partial.npz"
    np.savez(partial, **{k: v for k, v in arrays.items() if k != "t"})
    with pytest.raises(BadInputError, match="expected arrays address, data, src, t in the archive"):
        read_frames(partial)
    corrupt = tmp_path / "corrupt.npz"
    corrupt.write_bytes(FIXTURE.read_bytes()[:5000])
    with pytest.raises(BadInputError, match="cannot read the .npz archive"):
        read_frames(corrupt)
    single = tmp_path / "single.npz"
    with open(single, "wb") as fh:
        np.save(fh, arrays["t"])
    with pytest.raises(BadInputError, match="expected an archive of arrays .*, got a single array"):
        read_frames(single)
