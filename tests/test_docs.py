"""The documentation site builds strictly, and its generated figures match the results.

The README's results table and the docs' validation tables are generated from
``benchmarks/results/*.json`` (``docs/_gen_tables.py``); a figure edited by hand, or a result
re-run without regenerating the README, fails here.
"""

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _gen_tables():
    spec = importlib.util.spec_from_file_location("_gen_tables", ROOT / "docs" / "_gen_tables.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readme_results_table_matches_the_results():
    problems = _gen_tables().check_readme()
    assert not problems, "\n".join([*problems, "run: python docs/_gen_tables.py --write"])


def test_a_hand_edited_figure_fails_the_check(tmp_path):
    gen = _gen_tables()
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text[text.index(gen.README_BEGIN) : text.index(gen.README_END)]
    row = next(line for line in block.splitlines() if "external_drives" in line and "%" in line)
    edited_row = row.replace("+1.", "+0.", 1) if "+1." in row else row.replace("%", "0 %", 1)
    assert edited_row != row
    edited = tmp_path / "README.md"
    edited.write_text(text.replace(row, edited_row), encoding="utf-8")
    problems = gen.check_readme(edited)
    assert problems and "external_drives" in problems[0]


def test_every_result_file_named_in_the_docs_exists():
    gen = _gen_tables()
    stems = set(gen.result_stems())
    assert gen.named_on_pages() <= stems


def test_the_results_writer_records_where_a_figure_came_from(tmp_path):
    sys.path.insert(0, str(ROOT))
    try:
        from benchmarks._results import figure, write_result
    finally:
        sys.path.remove(str(ROOT))
    path = write_result(
        "demo_bench",
        {"per_drive_s": [0.4, float("nan")]},
        figures=[figure("fit time", 0.4, unit="s", target=("<=", 1.0), count=2)],
        path=tmp_path / "demo_bench.json",
        quick=False,
    )
    result = json.loads(path.read_text())
    assert result["benchmark"] == "demo_bench"
    assert result["per_drive_s"] == [0.4, None]
    run = result["run"]
    assert {"revision", "date", "machine", "wall_s", "cpu_s", "peak_rss_mb"} <= set(run)
    assert {"commit", "dirty"} <= set(run["revision"])
    assert {"cores", "cpu_model"} <= set(run["machine"])
    (fig,) = result["figures"]
    assert fig["met"] is True and fig["target"] == {"op": "<=", "value": 1.0}


def test_the_benchmark_runner_lists_every_script():
    out = subprocess.run(
        [sys.executable, "-m", "benchmarks", "--list"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    ).stdout
    for name in ("tyre_speed", "external_drives", "fleet_run"):
        assert name in out


def test_mkdocs_build_strict(tmp_path):
    if importlib.util.find_spec("mkdocs") is None:
        pytest.skip("mkdocs is not installed (pip install '.[test]')")
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert done.returncode == 0, done.stderr[-4000:]
    assert (tmp_path / "site" / "validation" / "index.html").exists()
