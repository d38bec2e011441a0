"""The benchmarks' one writer: JSON conversion and atomic figure files."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib
import numpy as np

from benchmarks._results import save_figure, to_jsonable

matplotlib.use("Agg")


def test_to_jsonable_gives_plain_json_values():
    value = {"a": np.arange(3), "b": np.float64(math.nan), "c": (np.int64(2), Path("x.json"))}
    assert to_jsonable(value) == {"a": [0, 1, 2], "b": None, "c": [2, "x.json"]}


def test_save_figure_writes_the_file_and_leaves_no_temporary(tmp_path):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0.0, 1.0])
    path = save_figure(fig, tmp_path / "plots" / "line.png", dpi=40)
    plt.close(fig)
    assert path == tmp_path / "plots" / "line.png"
    assert path.read_bytes()[:4] == b"\x89PNG"
    assert [p.name for p in path.parent.iterdir()] == ["line.png"]
