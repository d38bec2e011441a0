"""benchmarks/api_surface.py's count of the benchmarks' imports of internal tyrebayes paths."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


@pytest.fixture
def api_surface(monkeypatch):
    monkeypatch.syspath_prepend(str(BENCHMARKS))  # the script imports _results as its sibling
    import api_surface

    yield api_surface
    sys.modules.pop("api_surface", None)


def test_the_benchmarks_import_no_internal_path_outside_internal(api_surface):
    found = api_surface.benchmark_imports()
    assert found["internal"] == []
    assert found["scripts_with_internal"] == 0
    assert "rss_mb" in found["internal_names"]
    # The children that run on another revision's package are listed, with their reason.
    assert "stream_stage_speed._CHILD" in found["excluded"]


def test_internal_paths_are_told_from_public_names(api_surface, tmp_path, monkeypatch):
    (tmp_path / "benchmarks").mkdir()
    (tmp_path / "benchmarks" / "one.py").write_text(
        "from tyrebayes import fit_tyre\n"
        "from tyrebayes.simulate import simulate_drive\n"
        "from tyrebayes.inference.online import run_online\n"
        "from tyrebayes.inference import vmax\n"
        "from tyrebayes.cli import main\n"
        "from tyrebayes._domain import load_vehicle\n"
        "from tyrebayes.simulate.drive import simulate_drive as again\n"
        "from tyrebayes.batch import _private\n"
        "import tyrebayes.inference.online.laplace_update\n"
        'CHILD = "from tyrebayes.batch.settings import configure_jax"\n'
    )
    scripts = '[project.scripts]\ntyrebayes = "tyrebayes.cli:main"\n'
    (tmp_path / "pyproject.toml").write_text(scripts)
    monkeypatch.setattr(api_surface, "ROOT", tmp_path)
    found = api_surface.benchmark_imports()
    assert [line.split(": ")[1] for line in found["internal"]] == [
        "tyrebayes._domain.load_vehicle",
        "tyrebayes.simulate.drive.simulate_drive",
        "tyrebayes.batch._private",
        "tyrebayes.inference.online.laplace_update",
        "tyrebayes.batch.settings.configure_jax",
    ]
    assert found["scripts_with_internal"] == 1
