"""mkdocs hook: the results tables, generated from ``benchmarks/results/*.json`` at build time.

A page's ``<!-- figures: NAME -->`` line becomes result ``NAME.json``'s table
(``docs/_gen_tables.py``), so the site cannot show a figure other than the committed one.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "_gen_tables", Path(__file__).resolve().parent / "_gen_tables.py"
)
_gen = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_gen)


def on_page_markdown(markdown, page, config, files):  # noqa: ARG001 (mkdocs' hook signature)
    return _gen.render_markers(markdown, Path(config["docs_dir"]))
