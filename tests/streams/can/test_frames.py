"""python-can readers (ASC, BLF): integrity checks python-can leaves out, suffixes."""

from __future__ import annotations

import pytest

from tyrebayes import BadInputError
from tyrebayes.simulate.can_log import write_can_log
from tyrebayes.streams.can import read_frames


@pytest.mark.parametrize("suffix", [".asc", ".blf"])
def test_truncated_file(messages, tmp_path, suffix):
    whole = write_can_log(messages, tmp_path / f"whole{suffix}").read_bytes()
    cut = tmp_path / f"cut{suffix}"
    cut.write_bytes(whole[: int(0.7 * len(whole))])
    with pytest.raises(BadInputError, match="truncated file"):
        read_frames(cut)
    frames, counts = read_frames(tmp_path / f"whole{suffix}")
    assert counts.frames == len(messages) == frames.time_s.size


def test_garbage_line_in_asc(messages, tmp_path):
    path = write_can_log(messages, tmp_path / "drive.asc")
    lines = path.read_text().splitlines()
    lines.insert(30, "%%% not an ASC line")
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(BadInputError, match="line 31: expected an ASC frame or header line"):
        read_frames(path)


def test_not_a_blf_file(tmp_path):
    path = tmp_path / "text.blf"
    path.write_text("hello")
    with pytest.raises(BadInputError, match="expected a BLF file header 'LOGG'"):
        read_frames(path)


def test_garbage_python_can_csv(messages, tmp_path):
    path = write_can_log(messages[:20], tmp_path / "drive.csv")
    path.write_text(path.read_text() + "1.0,this,is,not,a,frame\n")
    with pytest.raises(BadInputError, match="cannot read past frame 20"):
        read_frames(path)


def test_suffix_and_missing_file(tmp_path):
    with pytest.raises(BadInputError, match=r"expected a suffix in \['.log'"):
        read_frames(tmp_path / "bus.txt")
    with pytest.raises(BadInputError, match="expected a readable file"):
        read_frames(tmp_path / "missing.blf")


def test_truncated_mf4_bus_log(messages, tmp_path, capsys):
    from tyrebayes.cli import main

    whole = write_can_log(messages, tmp_path / "whole.mf4").read_bytes()
    cut = tmp_path / "cut.mf4"
    cut.write_bytes(whole[: len(whole) // 2])
    out = tmp_path / "out.parquet"
    code = main(["convert", str(cut), "--profile", "toyota_rav4_2017", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "cut.mf4: cannot open" in err and err.count("\n") == 1
    assert not out.exists()
