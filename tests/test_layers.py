"""The package's layers hold: import-linter checks the contracts in ``pyproject.toml``.

The contracts (DESIGN.md): physics <- _domain <- streams <- inference <- decisions <- criticism <-
report <- commands; ``simulate`` uses physics and streams only and no library module imports it;
physics reads no files. A back-edge anywhere fails this test, and so the default test run.
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


def test_a_back_edge_breaks_the_contract(tmp_path, monkeypatch, capsys):
    """The same contracts on a copy of their layout with physics importing inference: broken."""
    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = contracts["contracts"][0]["layers"]
    package = tmp_path / "tyrebayes"
    for layer in layers:
        module = package / Path(*layer.split(".")[1:])
        module.mkdir(parents=True, exist_ok=True)
        (module / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    (package / "physics" / "tyre.py").write_text("from ..inference import fit\n")
    (package / "inference" / "fit.py").write_text("")
    for name in ("simulate", "_resources", "internal", "_io", "_errors"):
        (package / name).mkdir(exist_ok=True)
        (package / name / "__init__.py").write_text("")
    # Modules of the real package (cli, _io, ...) stand here as packages.
    config = tmp_path / "pyproject.toml"
    config.write_text((ROOT / "pyproject.toml").read_text())
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in [m for m in sys.modules if m == "tyrebayes" or m.startswith("tyrebayes.")]:
        monkeypatch.delitem(sys.modules, name)
    assert _lint(config, tmp_path) == 1
    out = capsys.readouterr().out
    assert "tyrebayes.physics is not allowed to import tyrebayes.inference" in out
