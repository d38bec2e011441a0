"""The public API's shape (issue 58): examples, typed results, module and function sizes, circles.

Measured from the source, not claimed:

1. **Examples**: the public callables (``tyrebayes.__all__``, classes and functions) whose
   docstring has a numpydoc ``Examples`` section, over all of them. The examples run as doctests in
   ``tests/test_doctests.py``; this counts the sections. Target: at least 90 %.
2. **Bare dict or tuple results**: the public functions (``tyrebayes.__all__``) whose return
   annotation is a ``dict`` or ``tuple`` (alone or in a union, such as ``dict | None``). Target: 0.
   The same count over every public module-level function of the package (a module and function
   without a leading underscore, outside ``tyrebayes._commands``) is reported beside it, without a
   target, with the names.
3. **Modules over 500 lines**: the package's ``.py`` files longer than 500 lines. Target: 0.
4. **Functions over 80 lines**: every ``def`` of the package (methods and nested functions too),
   measured from its ``def`` line (decorators excluded) to its last line, less its docstring: a
   numpydoc docstring with its Examples (what issue 58 asks for) is not code to split. Target: at
   most 5. The count with docstrings is reported beside it, without a target.
5. **String-keyed ``windows[...]`` lookups**: subscripts ``windows["name"]`` (a name or attribute
   called ``windows`` indexed by a string constant) in the package and the benchmarks, which a
   typed window table replaces. Target: 0.
6. **Import circles**: the strongly connected components of more than one module in the package's
   import graph (grimp, every import in a module, those inside functions included), and the
   circles between sibling modules or packages that import-linter's ``acyclic_siblings`` contract
   forbids. Target: 0 for both.
7. **Benchmark imports of internal paths**: the imports of tyrebayes in ``benchmarks/*.py`` (and
   in the child-process sources their strings hold) that are not its public API (module
   :mod:`benchmarks` says what is), outside ``benchmarks/_internal.py``, the one module that
   holds the internal names benchmarks use on purpose. Target: 0; children run on another
   revision's package (``_internal.REVISION_CHILDREN``) are listed as exclusions. The number of
   internal names ``_internal.py`` holds is reported beside it, without a target.

With ``--before REV`` the same counts are taken on the package and benchmarks as of git revision
REV (extracted with ``git archive``, counted in a child process) and saved beside them.

Usage: ``python benchmarks/api_surface.py [--out PATH] [--before REV]`` (seconds; it imports the
package).
"""

from __future__ import annotations

import argparse
import ast
import inspect
import re
import sys
import types
from pathlib import Path

from _results import figure, write_result  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "tyrebayes"

MAX_MODULE_LINES = 500
MAX_FUNCTION_LINES = 80
MAX_LONG_FUNCTIONS = 5
EXAMPLES_TARGET = 90.0

_SECTION = re.compile(r"^(?P<name>[A-Z][A-Za-z ]*)\n-+$", re.M)
_BARE = re.compile(r"^(typing\.)?(dict|tuple|Dict|Tuple)\b")


def _sections(doc: str) -> set[str]:
    return {m["name"] for m in _SECTION.finditer(doc)}


def _is_bare(annotation: str) -> bool:
    """Whether a return annotation (as written) is a dict or a tuple, alone or in a union."""
    text = annotation.strip().strip("'\"")
    if text.startswith("Optional[") and text.endswith("]"):
        text = text[len("Optional[") : -1]
    return any(_BARE.match(part.strip()) for part in _split_union(text))


def _split_union(text: str) -> list[str]:
    """``a | b[c | d]`` -> ``["a", "b[c | d]"]``: the union's top-level members."""
    parts, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        if ch in "[(":
            depth += 1
        elif ch in "])":
            depth -= 1
        elif ch == "|" and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def _return_annotation(obj) -> str | None:
    """The return annotation as written in the source (``None``: not annotated)."""
    try:
        annotation = inspect.signature(obj).return_annotation
    except (TypeError, ValueError):
        return None
    if annotation is inspect.Signature.empty:
        return None
    return annotation if isinstance(annotation, str) else inspect.formatannotation(annotation)


def public_callables() -> dict[str, object]:
    import tyrebayes as tb

    return {
        name: getattr(tb, name)
        for name in tb.__all__
        if callable(getattr(tb, name)) and not isinstance(getattr(tb, name), types.ModuleType)
    }


def examples() -> dict:
    names = public_callables()
    with_examples = sorted(
        n for n, o in names.items() if "Examples" in _sections(inspect.getdoc(o) or "")
    )
    without = sorted(set(names) - set(with_examples))
    return {"total": len(names), "with_examples": with_examples, "without_examples": without}


def _modules() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def bare_results() -> dict:
    """Public functions whose return annotation is a bare dict or tuple."""
    public = [
        (name, obj)
        for name, obj in public_callables().items()
        if inspect.isfunction(obj) or inspect.isbuiltin(obj)
    ]
    in_all = sorted(
        f"{name} -> {ann}"
        for name, obj in public
        if (ann := _return_annotation(obj)) is not None and _is_bare(ann)
    )
    unannotated = sorted(name for name, obj in public if _return_annotation(obj) is None)
    package = []
    for path in _modules():
        module = _module_name(path)
        if any(p.startswith("_") and p != "__init__" for p in module.split(".")[1:]):
            continue
        tree = ast.parse(path.read_text())
        for node in tree.body:
            is_def = isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
            if is_def and not node.name.startswith("_"):
                if node.returns is not None and _is_bare(ast.unparse(node.returns)):
                    package.append(f"{module}.{node.name} -> {ast.unparse(node.returns)}")
    return {
        "public_functions": len(public),
        "in_all": in_all,
        "in_all_unannotated": unannotated,
        "package": sorted(package),
    }


def sizes() -> dict:
    long_modules, long_functions, long_with_docstrings = {}, {}, {}
    for path in _modules():
        text = path.read_text()
        rel = str(path.relative_to(ROOT))
        n_lines = len(text.splitlines())
        if n_lines > MAX_MODULE_LINES:
            long_modules[rel] = n_lines
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                where = f"{rel}:{node.lineno} {node.name}"
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    long_with_docstrings[where] = length
                code = length - _docstring_lines(node)
                if code > MAX_FUNCTION_LINES:
                    long_functions[where] = code
    return {
        "modules": len(_modules()),
        "long_modules": dict(sorted(long_modules.items(), key=lambda kv: -kv[1])),
        "long_functions": dict(sorted(long_functions.items(), key=lambda kv: -kv[1])),
        "long_functions_with_docstrings": dict(
            sorted(long_with_docstrings.items(), key=lambda kv: -kv[1])
        ),
    }


def _docstring_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines of the function's docstring (0 without one)."""
    first = node.body[0]
    if (
        isinstance(first, ast.Expr)
        and isinstance(first.value, ast.Constant)
        and isinstance(first.value.value, str)
    ):
        return first.end_lineno - first.lineno + 1
    return 0


def _strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components (iterative), those of more than one node."""
    index, low, on_stack, stack, out = {}, {}, set(), [], []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            advanced = False
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                    advanced = True
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            if advanced:
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    out.append(sorted(component))
    return out


def circles() -> dict:
    import grimp

    graph = grimp.build_graph("tyrebayes", include_external_packages=False)
    modules = sorted(graph.modules)
    edges = {m: set(graph.find_modules_directly_imported_by(m)) for m in modules}
    module_cycles = _strongly_connected(edges)

    # Sibling circles (import-linter's acyclic_siblings): under each parent, an edge from sibling
    # A to sibling B when any module inside A imports any module inside B.
    def sibling_of(module: str, parent: str) -> str | None:
        prefix = parent + "."
        if not module.startswith(prefix):
            return None
        return prefix + module[len(prefix) :].split(".")[0]

    sibling_cycles = []
    parents = {m.rsplit(".", 1)[0] for m in modules if "." in m}
    for parent in sorted(parents):
        siblings: dict[str, set[str]] = {}
        for m in modules:
            a = sibling_of(m, parent)
            if a is None:
                continue
            siblings.setdefault(a, set())
            for target in edges[m]:
                b = sibling_of(target, parent)
                if b is not None and b != a:
                    siblings[a].add(b)
        sibling_cycles += _strongly_connected(siblings)
    return {"module_cycles": module_cycles, "sibling_cycles": sibling_cycles}


def windows_lookups() -> list[str]:
    """``path:line`` of every ``windows["..."]`` subscript in the package and the benchmarks."""
    found = []
    for folder in (PACKAGE, ROOT / "benchmarks"):
        for path in sorted(folder.rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if not isinstance(node, ast.Subscript):
                    continue
                target = node.value
                name = target.id if isinstance(target, ast.Name) else getattr(target, "attr", "")
                key = node.slice
                if (
                    name == "windows"
                    and isinstance(key, ast.Constant)
                    and isinstance(key.value, str)
                ):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    return found


def _public_namespace(module: str) -> set[str] | None:
    """The public names of package ``module``, or ``None`` when it is not a public namespace.

    ``tyrebayes``: its ``__all__``. A subpackage without a ``_``-prefixed part (and not
    ``tyrebayes.internal``): its ``__all__`` where it defines one, else the names its
    ``__init__.py`` re-exports as ``from .module import name as name`` (PEP 484's re-export form),
    and its own public subpackages. A module file is no namespace.
    """
    import importlib

    parts = module.split(".")
    init = PACKAGE.joinpath(*parts[1:], "__init__.py")
    if parts[0] != "tyrebayes" or not init.exists():
        return None
    if any(p.startswith("_") for p in parts) or module == "tyrebayes.internal":
        return None
    names = getattr(importlib.import_module(module), "__all__", None)
    if names is None:
        names = [
            alias.name
            for node in ast.parse(init.read_text()).body
            if isinstance(node, ast.ImportFrom) and node.level >= 1
            for alias in node.names
            if alias.asname == alias.name
        ]
    packages = {
        child.parent.name
        for child in init.parent.glob("*/__init__.py")
        if not child.parent.name.startswith("_") and child.parent.name != "internal"
    }
    return {n for n in names if not n.startswith("_")} | packages


def _entry_points() -> set[tuple[str, str]]:
    """(module, name) of the console scripts pyproject.toml declares (``tyrebayes.cli:main``)."""
    import tomllib

    pyproject = ROOT / "pyproject.toml"
    if not pyproject.exists():
        return set()
    scripts = tomllib.loads(pyproject.read_text()).get("project", {}).get("scripts", {})
    return {tuple(target.split(":", 1)) for target in scripts.values()}


def _imports(tree: ast.AST) -> list[tuple[int, str, str | None]]:
    """(line, module, name) of each import of tyrebayes in ``tree``; name ``None``: the module."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name, None) for a in node.names if a.name[:9] == "tyrebayes"]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] == "tyrebayes":
                found += [(node.lineno, node.module, a.name) for a in node.names]
    return found


def _child_sources(tree: ast.Module) -> dict[str, ast.AST]:
    """The module-level strings that are Python importing tyrebayes (a child process's source)."""
    sources = {}
    for node in tree.body:
        if not (isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant)):
            continue
        text = node.value.value
        if not isinstance(text, str) or "tyrebayes" not in text:
            continue
        try:
            child = ast.parse(text)
        except SyntaxError:
            continue
        if _imports(child):
            for target in node.targets:
                if isinstance(target, ast.Name):
                    sources[target.id] = child
    return sources


def _internal_tables() -> dict[str, dict]:
    """``benchmarks/_internal.py``'s tables, read from its source (nothing is imported)."""
    path = ROOT / "benchmarks" / "_internal.py"
    tables: dict[str, dict] = {"INTERNAL": {}, "INTERNAL_MODULES": {}, "REVISION_CHILDREN": {}}
    if not path.exists():
        return tables
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.AnnAssign | ast.Assign):
            target = node.target if isinstance(node, ast.AnnAssign) else node.targets[0]
            if isinstance(target, ast.Name) and target.id in tables and node.value is not None:
                tables[target.id] = ast.literal_eval(node.value)
    return tables


def benchmark_imports() -> dict:
    """The benchmarks' imports of tyrebayes that are not its public API.

    Public: a name of a public namespace (:func:`_public_namespace`), such a namespace itself, or
    a console script's entry point (``tyrebayes.cli.main``, what the ``tyrebayes`` command runs);
    everything else (a module path below a subpackage, a ``_``-prefixed name or module) is
    internal. Every ``benchmarks/*.py`` but ``_internal.py`` is read, with the sources of the
    child processes its strings hold; the children ``_internal.REVISION_CHILDREN`` names run on
    another git revision's package and are listed apart.
    """
    tables = _internal_tables()
    namespaces: dict[str, set[str] | None] = {}
    entry_points = _entry_points()

    def public(module: str, name: str | None) -> bool:
        if (module, name) in entry_points:
            return True
        if name is None:
            return module == "tyrebayes" or bool(_public_namespace(module) is not None)
        if name.startswith("_"):
            return False
        if module not in namespaces:
            namespaces[module] = _public_namespace(module)
        return namespaces[module] is not None and name in namespaces[module]

    internal, excluded, scripts = [], {}, 0
    for path in sorted((ROOT / "benchmarks").glob("*.py")):
        if path.name == "_internal.py":
            continue
        tree = ast.parse(path.read_text())
        sources = {"": tree, **_child_sources(tree)}
        found_here = False
        for label, source in sources.items():
            where = f"{path.stem}.{label}" if label else path.stem
            bad = [
                f"benchmarks/{path.name}{'::' + label if label else ''}:{line}: "
                f"{module}{'.' + name if name else ''}"
                for line, module, name in _imports(source)
                if not public(module, name)
            ]
            if bad and where in tables["REVISION_CHILDREN"]:
                excluded[where] = f"{len(bad)} imports: {tables['REVISION_CHILDREN'][where]}"
            elif bad:
                internal += bad
                found_here = True
        scripts += found_here
    return {
        "internal": internal,
        "scripts_with_internal": scripts,
        "excluded": excluded,
        "internal_names": sorted(tables["INTERNAL"]) + sorted(tables["INTERNAL_MODULES"]),
    }


_BEFORE_CHILD = r"""
import json, sys
from pathlib import Path
folder, here = Path(sys.argv[1]), sys.argv[2]
sys.path[:0] = [str(folder), here]
import api_surface as a
a.ROOT, a.PACKAGE = folder, folder / "tyrebayes"
ex, bare, size, circ = a.examples(), a.bare_results(), a.sizes(), a.circles()
print(json.dumps({
    "public callables with an Examples section": [len(ex["with_examples"]), ex["total"]],
    "public functions returning a bare dict or tuple": len(bare["in_all"]),
    "modules over 500 lines": len(size["long_modules"]),
    "functions over 80 lines (docstring excluded)": len(size["long_functions"]),
    "string-keyed windows lookups": len(a.windows_lookups()),
    "import circles between modules": len(circ["module_cycles"]),
    "benchmark imports of internal tyrebayes paths": len(a.benchmark_imports()["internal"]),
}))
"""


def counts_at(revision: str) -> dict:
    """The headline counts on the package and benchmarks as of git ``revision``."""
    import json
    import os
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        archive = subprocess.run(
            ["git", "archive", revision, "tyrebayes", "models", "benchmarks", "pyproject.toml"],
            cwd=ROOT,
            capture_output=True,
            check=True,
        ).stdout
        subprocess.run(["tar", "-x", "-C", tmp], input=archive, check=True)
        child = subprocess.run(
            [sys.executable, "-c", _BEFORE_CHILD, tmp, str(Path(__file__).resolve().parent)],
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONPATH": tmp},
            cwd=tmp,
            check=True,
        )
    return {"revision": revision, **json.loads(child.stdout.strip().splitlines()[-1])}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--before", help="git revision to count as the before")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))

    ex = examples()
    bare = bare_results()
    size = sizes()
    circ = circles()
    lookups = windows_lookups()
    bench = benchmark_imports()
    share = 100.0 * len(ex["with_examples"]) / ex["total"]
    figures = [
        figure(
            "public callables with an Examples section",
            round(share, 1),
            unit="%",
            target=(">=", EXAMPLES_TARGET),
            count=ex["total"],
            note=f"{len(ex['with_examples'])} of {ex['total']} names in tyrebayes.__all__",
        ),
        figure(
            "public functions returning a bare dict or tuple (by annotation)",
            len(bare["in_all"]),
            target=("==", 0),
            count=bare["public_functions"],
            exclusions={n: "no return annotation" for n in bare["in_all_unannotated"]},
        ),
        figure(
            "package functions returning a bare dict or tuple (by annotation)",
            len(bare["package"]),
            count=None,
            note="public module-level functions of every public module, not only __all__",
        ),
        figure(
            f"modules over {MAX_MODULE_LINES} lines",
            len(size["long_modules"]),
            target=("==", 0),
            count=size["modules"],
        ),
        figure(
            f"functions over {MAX_FUNCTION_LINES} lines (docstring excluded)",
            len(size["long_functions"]),
            target=("<=", MAX_LONG_FUNCTIONS),
        ),
        figure(
            f"functions over {MAX_FUNCTION_LINES} lines (docstring included)",
            len(size["long_functions_with_docstrings"]),
        ),
        figure(
            'string-keyed windows["..."] lookups',
            len(lookups),
            target=("==", 0),
            note="in tyrebayes/ and benchmarks/",
        ),
        figure(
            "import circles between modules",
            len(circ["module_cycles"]),
            target=("==", 0),
            note="strongly connected components of the module import graph (grimp)",
        ),
        figure(
            "import circles between sibling modules or packages",
            len(circ["sibling_cycles"]),
            target=("==", 0),
            note="what import-linter's acyclic_siblings contract forbids",
        ),
        figure(
            "benchmark imports of internal tyrebayes paths outside benchmarks/_internal.py",
            len(bench["internal"]),
            target=("==", 0),
            count=bench["scripts_with_internal"],
            exclusions=bench["excluded"],
            note="count: scripts with such an import; benchmarks/*.py and their child sources",
        ),
        figure(
            "internal names held by benchmarks/_internal.py",
            len(bench["internal_names"]),
            note="the internal steps, constants and modules benchmarks use on purpose",
        ),
    ]
    payload = {
        "examples": ex,
        "bare_results": bare,
        "sizes": size,
        "circles": circ,
        "windows_lookups": lookups,
        "benchmark_imports": bench,
    }
    if args.before:
        payload["before"] = counts_at(args.before)
        print(f"before ({args.before}): {payload['before']}")
    write_result("api_surface", payload, figures=figures, path=args.out)
    for f in figures:
        met = "" if f["met"] is None else (" met" if f["met"] else " MISSED")
        print(f"{f['name']}: {f['value']}{f['unit']}{met}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
