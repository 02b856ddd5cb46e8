"""The architecture guard: the layers of ``docs/architecture.md`` against the imports.

Reads the sources with :mod:`ast` (redres itself is never imported): every import of a
redres module, at module level, deferred inside a function or under ``TYPE_CHECKING``,
and ``importlib.import_module("redres.…")`` with a constant name. Checks that there is no
cycle among modules or among units (a unit is the first component below ``redres``), no
import of a higher layer, and no private module of a unit imported from another unit.

Run as a script to list every violation (exit status 1 if any)::

    python tests/test_layers.py [docs/architecture.md] [--table "errors,_version;linalg;…"]
"""

from __future__ import annotations

import argparse
import ast
import functools
import re
import sys
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SOURCE = REPO / "src" / "redres"
DOC = REPO / "docs" / "architecture.md"

#: The planned layers, bottom first: the script's fallback while the doc has no table.
PLANNED = (
    "errors,_version,_toml,_validate,_compile;linalg;robot,models;tasks,objectives;resolution;"
    "control,dynamics,ik,testing;batch;scenarios;sweeps;report,viewer,warmup;cli,__init__,__main__"
)
KINDS = ("table", "unresolved", "module cycles", "package cycles", "upward", "private")


@dataclass(frozen=True, order=True)
class Edge:
    """One import of a redres module by another, where it is written."""

    importer: str
    imported: str
    file: str
    line: int

    def __str__(self) -> str:
        return f"{self.importer} -> {self.imported} ({self.file}:{self.line})"


def _table_after(text: str, heading: str, header: tuple[str, ...]) -> list[list[str]] | None:
    """Return the body rows of the table with ``header`` in the section ``heading``, or None."""
    lines = iter(text.splitlines())
    for line in lines:
        if line.startswith(heading):
            break
    for line in lines:
        if line.startswith("#"):
            return None
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.lstrip().startswith("|") and tuple(c.lower() for c in cells) == header:
            break
    else:
        return None
    rows = []
    for line in lines:
        if not line.lstrip().startswith("|"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not set("".join(cells)) <= set("-: "):
            rows.append(cells)
    return rows


def parse_layers(text: str) -> dict[str, int] | None:
    """Return unit → layer (1 = bottom) from the ``## Layers`` table, or None if absent."""
    rows = _table_after(text, "## Layers", ("layer", "units"))
    if rows is None:
        return None
    return {unit: int(row[0]) for row in rows for unit in re.findall(r"`([^`]+)`", row[1])}


def parse_internal(text: str) -> set[str]:
    """Return the modules of the optional ``## Internal APIs`` table."""
    rows = _table_after(text, "## Internal APIs", ("module", "used by")) or []
    return {name for row in rows for name in re.findall(r"`([^`]+)`", row[0])}


def parse_spec(spec: str) -> dict[str, int]:
    """Return unit → layer from ``"a,b;c;…"`` (layers bottom first, separated by ``;``)."""
    layers = [re.split(r"[,\s]+", part.strip()) for part in spec.split(";")]
    return {unit: i for i, units in enumerate(layers, 1) for unit in units if unit}


def find_modules(root: Path) -> dict[str, Path]:
    """Return dotted module name → file for every ``.py`` file of the package ``root``."""
    modules = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root.parent).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def unit_of(module: str) -> str:
    """Return the unit of ``module``: its first component below the top (``__init__``)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _targets(node: ast.AST, package: str, top: str, modules: dict[str, Path]) -> list[str]:
    """Return the modules below ``top`` that the import ``node`` (in ``package``) targets."""
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    elif isinstance(node, ast.ImportFrom):
        base = node.module or ""
        if node.level:
            parts = package.split(".")
            if node.level > len(parts):
                return []
            base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
        names = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
    elif (
        isinstance(node, ast.Call)
        and (getattr(node.func, "attr", None) or getattr(node.func, "id", None)) == "import_module"
        and node.args
        and isinstance(node.args[0], ast.Constant)
        and isinstance(node.args[0].value, str)
    ):
        names = [node.args[0].value]
    else:
        return []
    return [name for name in names if name == top or name.startswith(top + ".")]


def collect_edges(root: Path) -> tuple[dict[str, Path], list[Edge]]:
    """Return the modules of the package ``root`` and every import among them."""
    modules = find_modules(root)
    edges = set()
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        file = path.relative_to(root.parent).as_posix()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
            for target in _targets(node, package, root.name, modules):
                if target != name:
                    edges.add(Edge(name, target, file, getattr(node, "lineno", 0)))
    return modules, sorted(edges)


def _components(graph: dict[str, set[str]]) -> list[list[str]]:
    """Return the strongly connected components of more than one node (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = stack[stack.index(v) :]
            del stack[stack.index(v) :]
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _cycle_through(graph: dict[str, set[str]], start: str, component: list[str]) -> list[str]:
    """Return a shortest cycle from ``start`` back to itself inside ``component`` (BFS)."""
    parent: dict[str, str] = {}
    queue = [start]
    for v in queue:
        for w in sorted(graph[v] & set(component)):
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(parent[path[-1]])
                return [*reversed(path), start]
            if w not in parent:
                parent[w] = v
                queue.append(w)
    return component


def _cycles(edges: list[Edge], key: Callable[[str], str]) -> list[str]:
    """Return one report per cycle of ``edges`` with nodes mapped by ``key``."""
    graph: dict[str, set[str]] = defaultdict(set)
    for e in edges:
        if key(e.importer) != key(e.imported):
            graph[key(e.importer)].add(key(e.imported))
    reports = []
    for component in _components(graph):
        example = min((_cycle_through(graph, start, component) for start in component), key=len)
        inside = [
            e
            for e in edges
            if {key(e.importer), key(e.imported)} <= set(component)
            and key(e.importer) != key(e.imported)
        ]
        reports.append(
            f"cycle among {', '.join(component)} (e.g. {' -> '.join(example)}):\n"
            + "\n".join(f"  {e}" for e in inside)
        )
    return reports


def _is_private(module: str) -> bool:
    """Whether ``module`` is a private module inside a unit (``redres.x._y``)."""
    return any(part.startswith("_") for part in module.split(".")[2:])


def check(root: Path, layers: dict[str, int], internal: set[str]) -> dict[str, list[str]]:
    """Return the violations of every kind (see ``KINDS``) in the package ``root``.

    Args:
        root: The package directory (``src/redres``).
        layers: Unit → layer, 1 = bottom.
        internal: Private modules that other units may import (the Internal APIs table).

    Returns:
        Kind → list of reports (one per offending import, or per cycle).
    """
    modules, all_edges = collect_edges(root)
    edges = [e for e in all_edges if e.imported in modules]
    units = {unit_of(m) for m in modules}
    kernel = {m for m, p in modules.items() if p.name.endswith("_kernels.py")}
    constants = {  # the compiler's constant modules: _codes.py, _*_codes.py, _layout.py
        m
        for m, p in modules.items()
        if p.name in ("_codes.py", "_layout.py")
        or (p.name.startswith("_") and p.name.endswith("_codes.py"))
    }
    found: dict[str, list[str]] = {kind: [] for kind in KINDS}
    found["table"] = [f"unit {u} is missing from the layer table" for u in units - set(layers)]
    found["table"] += [f"unit {u} of the layer table does not exist" for u in set(layers) - units]
    found["table"] += [f"internal API {m} does not exist" for m in internal - set(modules)]
    found["table"].sort()
    found["unresolved"] = [str(e) for e in all_edges if e.imported not in modules]
    found["module cycles"] = _cycles(edges, str)
    found["package cycles"] = _cycles(edges, unit_of)
    for e in edges:
        a, b = unit_of(e.importer), unit_of(e.imported)
        if a != b and a in layers and b in layers and layers[b] > layers[a]:
            found["upward"].append(f"{e}  [layer {layers[a]} -> {layers[b]}]")
        allowed = e.importer in kernel and (e.imported in kernel or e.imported in constants)
        if a != b and _is_private(e.imported) and not allowed and e.imported not in internal:
            found["private"].append(str(e))
    return found


@functools.cache
def _violations() -> dict[str, list[str]]:
    """Check the real tree against the tables of ``docs/architecture.md``."""
    text = DOC.read_text(encoding="utf-8")
    layers = parse_layers(text)
    if layers is None:
        pytest.fail(f"{DOC} has no '## Layers' table with the header '| layer | units |'")
    return check(SOURCE, layers, parse_internal(text))


def _assert_none(kind: str) -> None:
    if found := _violations()[kind]:
        pytest.fail(f"{len(found)} {kind} violation(s):\n" + "\n".join(found), pytrace=False)


def test_layer_table_matches_units() -> None:
    _assert_none("table")


def test_imports_resolve() -> None:
    _assert_none("unresolved")


def test_no_module_cycle() -> None:
    _assert_none("module cycles")


def test_no_package_cycle() -> None:
    _assert_none("package cycles")


def test_no_upward_import() -> None:
    _assert_none("upward")


def test_no_private_import_across_packages() -> None:
    _assert_none("private")


#: Modules stay small enough to read whole: one concept each (docs/architecture.md).
MAX_MODULE_LINES = 500


def test_no_module_over_500_lines_and_a_small_top_level() -> None:
    lines = {str(f.relative_to(SOURCE)): len(f.read_text(encoding="utf-8").splitlines())
             for f in SOURCE.rglob("*.py")}  # fmt: skip
    long = {name: n for name, n in lines.items() if n > MAX_MODULE_LINES}
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}; split them by concept"
    top = sorted(f.name for f in SOURCE.glob("*.py"))
    assert len(top) <= 10, f"the top level holds {len(top)} files: {top}"


_SAMPLE_DOC = """## Layers

| layer | units |
|---|---|
| 1 | `low` |
| 2 | `mid` |
| 3 | `high` |
| 4 | `__init__`, `extra` |

## Internal APIs

| module | used by |
|---|---|
| `redres.low._secret` | `redres.mid.a` |
"""


def test_checker_catches_violations(tmp_path: Path) -> None:
    files = {
        "__init__.py": "from . import high\n",
        "low/__init__.py": "def f():\n    from ..high import x\n",
        "low/_secret.py": "",
        "low/_kernels.py": "",
        "low/_codes.py": "",
        "mid/__init__.py": "import typing\nif typing.TYPE_CHECKING:\n    from . import b\n",
        "mid/a.py": "from .b import y\nfrom redres.low import _secret\n",
        "mid/b.py": "import redres.mid.a\nimport importlib\nimportlib.import_module('redres.no')\n",
        "mid/_kernels.py": "from ..low import _kernels, _codes\nfrom .. import low\n",
        "high/__init__.py": "import redres\nx = 1\n",
    }
    root = tmp_path / "redres"
    for name, body in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(body, encoding="utf-8")
    layers = parse_layers(_SAMPLE_DOC)
    assert layers == {"low": 1, "mid": 2, "high": 3, "__init__": 4, "extra": 4}
    assert parse_internal(_SAMPLE_DOC) == {"redres.low._secret"}
    found = check(root, layers, set())
    assert found["table"] == ["unit extra of the layer table does not exist"]
    assert found["unresolved"] == ["redres.mid.b -> redres.no (redres/mid/b.py:3)"]
    assert [c.split(" (e.g.")[0] for c in found["module cycles"]] == [
        "cycle among redres, redres.high",
        "cycle among redres.mid.a, redres.mid.b",
    ]
    assert [c.split(" (e.g.")[0] for c in found["package cycles"]] == ["cycle among __init__, high"]
    assert [v.split("  [")[0] for v in found["upward"]] == [
        "redres.high -> redres (redres/high/__init__.py:1)",
        "redres.low -> redres.high (redres/low/__init__.py:2)",
    ]
    assert found["private"] == ["redres.mid.a -> redres.low._secret (redres/mid/a.py:2)"]
    assert check(root, layers, parse_internal(_SAMPLE_DOC))["private"] == []


def main(argv: list[str] | None = None) -> int:
    """Print every violation grouped by kind; return 1 if there is any."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("doc", nargs="?", type=Path, default=DOC, help="the architecture doc")
    parser.add_argument("--table", help='layers bottom first, e.g. "errors,_version;linalg;…"')
    args = parser.parse_args(argv)
    text = args.doc.read_text(encoding="utf-8")
    layers = parse_spec(args.table) if args.table else parse_layers(text)
    if layers is None:
        print(f"warning: {args.doc} has no layer table; using the planned one", file=sys.stderr)
        layers = parse_spec(PLANNED)
    found = check(SOURCE, layers, parse_internal(text))
    for kind in KINDS:
        print(f"== {kind}: {len(found[kind])}")
        print("\n".join(found[kind]))
    total = sum(map(len, found.values()))
    print(f"== total: {total} violation(s)")
    return 1 if total else 0


if __name__ == "__main__":
    sys.exit(main())
