"""The package's layers hold: import-linter checks the contracts in ``pyproject.toml``.

The contracts (DESIGN.md): physics <- _domain <- streams <- inference <- decisions <- criticism <-
report <- commands; ``simulate`` uses physics and streams only and no library module imports it;
physics reads no files; no two modules (or packages under one parent) import each other. A
back-edge or a circle anywhere fails this test, and so the default test run.
"""

from __future__ import annotations

import os
import sys
import tomllib
from pathlib import Path

from importlinter.cli import lint_imports

ROOT = Path(__file__).resolve().parents[1]


def _lint(config: Path, cwd: Path) -> int:
    here = Path.cwd()
    os.chdir(cwd)
    try:
        return lint_imports(config_filename=str(config), no_cache=True, no_logo=True)
    finally:
        os.chdir(here)


def test_the_package_keeps_its_layers():
    assert _lint(ROOT / "pyproject.toml", ROOT) == 0


def _skeleton(tmp_path, monkeypatch) -> Path:
    """The contracts' layout as empty packages, with the real ``pyproject.toml``; returns it."""
    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = contracts["contracts"][0]["layers"]
    package = tmp_path / "tyrebayes"
    for layer in layers:
        module = package / Path(*layer.split(".")[1:])
        module.mkdir(parents=True, exist_ok=True)
        (module / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    for name in ("simulate", "_resources", "internal", "_io", "_errors"):
        (package / name).mkdir(exist_ok=True)
        (package / name / "__init__.py").write_text("")
    # The one import the circle contract ignores (pyproject.toml says why) must exist.
    for sub in ("tyre", "lateral"):
        (package / "inference" / sub).mkdir()
        (package / "inference" / sub / "__init__.py").write_text("")
    (package / "inference" / "tyre" / "model.py").write_text("")
    (package / "inference" / "lateral" / "model.py").write_text("from ..tyre import model\n")
    # Modules of the real package (cli, _io, ...) stand here as packages.
    config = tmp_path / "pyproject.toml"
    config.write_text((ROOT / "pyproject.toml").read_text())
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in [m for m in sys.modules if m == "tyrebayes" or m.startswith("tyrebayes.")]:
        monkeypatch.delitem(sys.modules, name)
    return package


def test_a_back_edge_breaks_the_contract(tmp_path, monkeypatch, capsys):
    """The same contracts on a copy of their layout with physics importing inference: broken."""
    package = _skeleton(tmp_path, monkeypatch)
    (package / "physics" / "tyre.py").write_text("from ..inference import fit\n")
    (package / "inference" / "fit.py").write_text("")
    assert _lint(tmp_path / "pyproject.toml", tmp_path) == 1
    out = capsys.readouterr().out
    assert "tyrebayes.physics is not allowed to import tyrebayes.inference" in out


def test_an_import_circle_breaks_the_contract(tmp_path, monkeypatch, capsys):
    """Two modules of one package importing each other, even inside a function: broken."""
    package = _skeleton(tmp_path, monkeypatch)
    (package / "streams" / "frames.py").write_text(
        "def read():\n    from .candump import read_candump\n"
    )
    (package / "streams" / "candump.py").write_text("from .frames import read\n")
    assert _lint(tmp_path / "pyproject.toml", tmp_path) == 1
    assert "No cycles are allowed in tyrebayes.streams" in capsys.readouterr().out


def _circles(graph) -> list[list[str]]:
    """Strongly connected sets of more than one module (Tarjan), each sorted."""
    edges = {m: graph.find_modules_directly_imported_by(m) for m in graph.modules}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            members = []
            while True:
                w = stack.pop()
                members.append(w)
                if w == v:
                    break
            if len(members) > 1:
                found.append(sorted(members))

    for module in sorted(edges):
        if module not in index:
            visit(module)
    return found


def test_no_module_imports_itself_back():
    """No circle of modules at all, imports inside functions included (issue 58: 0 circles).

    The contract above judges packages, with one import between two packages left out; this
    judges every module, with none left out.
    """
    import grimp

    assert _circles(grimp.build_graph("tyrebayes", cache_dir=None)) == []
