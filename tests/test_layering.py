"""The package's import layering: no import cycles and no upward imports.

Every module of ``graphseg/`` is parsed with ``ast`` (nothing is imported), and
every ``import`` / ``from ... import`` in it, at module level or inside a
function, becomes an edge ``module -> imported module`` (relative imports
resolved; ``from p import name`` points at ``p.name`` when that is a module,
else at ``p``). Importing ``a.b.c`` does not add edges to the parent packages:
the edge names the module whose code is used. Imports by name through the
registries (``"graphseg.graphs.chamfer:Chamfer3D"`` strings) are plugins, not
imports, and are not edges.

The rules (``RULES``):

* ``graphseg.io`` and ``graphseg.graphs`` never import the method, the
  backends, the configuration or anything that drives a run;
* ``graphseg.backends`` imports only ``scene``, ``geometry``, ``io``,
  ``registry``, itself, the dependency-free helpers ``quiet`` (silences native libraries'
  logging) and ``validation`` (did-you-mean and finiteness checks of options)
  and ``background_config`` (the table-plane settings the geometric segmenter
  shares with the background step), and ``parallel`` (forked workers, for
  a lifter's own per-view and per-pair steps);
* the renderers (``report``, ``render_audit``) compute nothing: they import no
  graphseg module but each other;
* nothing imports ``graphseg.cli``;
* ``graphseg.method`` imports only the config, the graphs, io, the arrays of
  one run (``scene``, ``result``, ``geometry``) and the shared helpers: never
  the pipeline, the job, the store, the backends (but ``backends.imaging``) or
  the output folder;
* ``graphseg.config`` imports only plain data (``presets``, ``published``,
  ``background_config``), ``validation``, and the registries it validates
  names against; ``presets`` import only ``published``;
* ``graphseg.pipeline`` never imports what drives it (``job``, ``batch``,
  ``cli``, ``store``), the output folder, the renderers or ``sim``;
  ``graphseg.job`` never imports ``batch``, ``cli``, ``store`` or ``sim``;
  ``graphseg.store`` never imports ``batch``, ``cli`` or the renderers.

``ALLOWED`` lists, with the fix each needs, the violations that live in files
this change could not touch; :func:`test_allowed_edges_still_exist` fails once
one is fixed, so the list only shrinks.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "graphseg"

Edges = dict[tuple[str, str], list[int]]


def _under(name: str, prefixes: Iterable[str]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


_LOW_FORBIDDEN = (
    "graphseg.backends",
    "graphseg.method",
    "graphseg.config",
    "graphseg.job",
    "graphseg.pipeline",
    "graphseg.batch",
    "graphseg.cli",
    "graphseg.store",
    "graphseg.report",
    "graphseg.render_audit",
    "graphseg.audit",
    "graphseg.output",
)
_BACKENDS_MAY = ("graphseg.backends", "graphseg.scene", "graphseg.geometry", "graphseg.io", "graphseg.registry", "graphseg.quiet", "graphseg.validation", "graphseg.background_config", "graphseg.parallel")
_RENDERERS = ("graphseg.report", "graphseg.render_audit")
#: Plain data and helpers every layer may import.
_PLAIN = ("graphseg.config", "graphseg.presets", "graphseg.published", "graphseg.background_config", "graphseg.validation", "graphseg.registry")
#: What the method (``graphseg.method``) may import: the arrays, graphs and config of one run, nothing that drives it.
_METHOD_MAY = (
    *_PLAIN,
    "graphseg.method",
    "graphseg.geometry",
    "graphseg.graphs",
    "graphseg.io",
    "graphseg.result",
    "graphseg.scene",
    "graphseg.backends.imaging",  # colour conversion shared with the segmenters
)
#: What the configuration may import: plain data and the registries it validates names against.
_CONFIG_MAY = (
    *_PLAIN,
    "graphseg.graphs.registry",
    "graphseg.graphs.criterion",
)
#: What drives a run from outside: the pipeline and the job never import these.
_DRIVERS = ("graphseg.job", "graphseg.batch", "graphseg.cli", "graphseg.store")

#: (importer prefix, rule, predicate on the imported module: True = allowed).
RULES: list[tuple[str, str, Callable[[str], bool]]] = [
    ("graphseg.io", "io never imports " + ", ".join(_LOW_FORBIDDEN), lambda t: not _under(t, _LOW_FORBIDDEN)),
    ("graphseg.graphs", "graphs never imports " + ", ".join(_LOW_FORBIDDEN), lambda t: not _under(t, _LOW_FORBIDDEN)),
    ("graphseg.backends", "backends imports only " + ", ".join(_BACKENDS_MAY), lambda t: _under(t, _BACKENDS_MAY)),
    ("graphseg.report", "renderers import no graphseg module but each other", lambda t: _under(t, _RENDERERS)),
    ("graphseg.render_audit", "renderers import no graphseg module but each other", lambda t: _under(t, _RENDERERS)),
    ("graphseg", "nothing imports graphseg.cli", lambda t: not _under(t, ("graphseg.cli",))),
    ("graphseg.method", "method imports only " + ", ".join(_METHOD_MAY), lambda t: _under(t, _METHOD_MAY)),
    ("graphseg.config", "config imports only " + ", ".join(_CONFIG_MAY), lambda t: _under(t, _CONFIG_MAY)),
    ("graphseg.presets", "presets import only plain data", lambda t: _under(t, ("graphseg.published",))),
    ("graphseg.pipeline", "pipeline never imports " + ", ".join(_DRIVERS) + ", the output folder, the renderers or sim", lambda t: not _under(t, (*_DRIVERS, "graphseg.output", *_RENDERERS, "graphseg.sim"))),
    ("graphseg.job", "job never imports batch, cli, store or sim", lambda t: not _under(t, ("graphseg.batch", "graphseg.cli", "graphseg.store", "graphseg.sim"))),
    ("graphseg.store", "store never imports batch, cli or the renderers", lambda t: not _under(t, ("graphseg.batch", "graphseg.cli", *_RENDERERS))),
]

#: Violations in files this change may not edit: edge -> the fix it needs.
ALLOWED: dict[tuple[str, str], str] = {}


def module_index(root: Path) -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is_package) for every ``.py`` file under ``root``."""
    out: dict[str, tuple[Path, bool]] = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        if is_pkg:
            parts = parts[:-1]
        out[".".join(parts)] = (path, is_pkg)
    return out


def import_edges(root: Path) -> Edges:
    """Edges ``(importer, imported)`` between modules of the package at ``root`` -> line numbers."""
    mods = module_index(root)
    top = root.name

    def resolve(name: str) -> str | None:
        while name and name not in mods:
            name = name.rpartition(".")[0]
        return name or None

    edges: Edges = {}
    for mod, (path, is_pkg) in mods.items():
        package = mod if is_pkg else mod.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")
                    base = base[: len(base) - (node.level - 1)]
                    where = ".".join(base + ([node.module] if node.module else []))
                else:
                    where = node.module or ""
                targets = [f"{where}.{a.name}" if f"{where}.{a.name}" in mods else where for a in node.names]
            for t in targets:
                if t != top and not t.startswith(top + "."):
                    continue
                r = resolve(t)
                lines = edges.setdefault((mod, r), []) if r is not None and r != mod else None
                if lines is not None and node.lineno not in lines:
                    lines.append(node.lineno)
    return edges


def cycles(edges: Iterable[tuple[str, str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative), each sorted."""
    graph: dict[str, list[str]] = {}
    for a, b in edges:
        graph.setdefault(a, []).append(b)
        graph.setdefault(b, [])
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    x = stack.pop()
                    on_stack.discard(x)
                    comp.append(x)
                    if x == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


def upward(edges: Mapping[tuple[str, str], list[int]]) -> list[tuple[str, str, str]]:
    """``(importer, imported, rule)`` for every edge that breaks one of :data:`RULES`."""
    bad = []
    for (a, b), _ in sorted(edges.items()):
        for prefix, text, ok in RULES:
            if _under(a, (prefix,)) and not ok(b):
                bad.append((a, b, text))
    return bad


def _where(edges: Edges, a: str, b: str) -> str:
    return f"{a} -> {b} (line {', '.join(map(str, edges[(a, b)]))})"


@pytest.fixture(scope="module")
def edges() -> Edges:
    return import_edges(ROOT)


def test_no_import_cycles(edges):
    kept = {e: lines for e, lines in edges.items() if e not in ALLOWED}
    found = cycles(kept)
    lines = []
    for comp in found:
        inside = set(comp)
        lines.append("cycle: " + ", ".join(comp))
        lines += ["    " + _where(edges, a, b) for (a, b) in sorted(kept) if a in inside and b in inside]
    print("\n".join(lines))
    assert not found, "import cycles:\n" + "\n".join(lines)


def test_no_upward_imports(edges):
    bad = [(a, b, rule) for a, b, rule in upward(edges) if (a, b) not in ALLOWED]
    text = "\n".join(f"{_where(edges, a, b)}: {rule}" for a, b, rule in bad)
    print(text)
    assert not bad, "upward imports:\n" + text


def test_allowed_edges_still_exist(edges):
    # an allow-listed edge that is gone must leave the list (it only shrinks)
    gone = [e for e in ALLOWED if e not in edges]
    assert not gone, f"fixed, remove from ALLOWED: {gone}"
    in_cycle = {e for comp in cycles(edges) for e in edges if e[0] in comp and e[1] in comp}
    useless = [e for e in ALLOWED if e not in in_cycle and not any((a, b) == e for a, b, _ in upward(edges))]
    assert not useless, f"allowed edges that break no rule: {useless}"


# ------------------------------------------------------------------ the walker itself
def _package(tmp_path: Path, files: Mapping[str, str]) -> Path:
    root = tmp_path / "graphseg"
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return root


def test_walker_resolves_relative_and_local_imports(tmp_path):
    root = _package(
        tmp_path,
        {
            "__init__.py": "",
            "scene.py": "",
            "io/__init__.py": "from .images import read\n",
            "io/images.py": "def read():\n    from ..scene import View\n",
            "graphs/__init__.py": "",
            "graphs/a.py": "import numpy\nfrom . import b\nfrom graphseg.io import images\n",
            "graphs/b.py": "def f():\n    from ..backends.x import y\n",
            "backends/__init__.py": "",
            "backends/x.py": "import graphseg.graphs.a\n",
        },
    )
    e = import_edges(root)
    assert set(e) == {
        ("graphseg.io", "graphseg.io.images"),
        ("graphseg.io.images", "graphseg.scene"),
        ("graphseg.graphs.a", "graphseg.graphs.b"),
        ("graphseg.graphs.a", "graphseg.io.images"),
        ("graphseg.graphs.b", "graphseg.backends.x"),
        ("graphseg.backends.x", "graphseg.graphs.a"),
    }
    assert e[("graphseg.graphs.b", "graphseg.backends.x")] == [2]
    # the local import closes a cycle and is an upward import twice over
    assert cycles(e) == [["graphseg.backends.x", "graphseg.graphs.a", "graphseg.graphs.b"]]
    bad = {(a, b) for a, b, _ in upward(e)}
    assert bad == {("graphseg.graphs.b", "graphseg.backends.x"), ("graphseg.backends.x", "graphseg.graphs.a")}


def test_walker_sees_a_two_module_cycle_and_nothing_in_a_clean_package(tmp_path):
    assert cycles([("a", "b"), ("b", "c"), ("c", "a"), ("c", "d")]) == [["a", "b", "c"]]
    assert cycles([("a", "b"), ("b", "c")]) == []
    root = _package(tmp_path, {"__init__.py": "", "scene.py": "", "geometry.py": "from .scene import x\n"})
    e = import_edges(root)
    assert cycles(e) == [] and upward(e) == []


if __name__ == "__main__":  # python tests/test_layering.py: print every edge that breaks a rule
    found = import_edges(ROOT)
    for comp in cycles(found):
        print("cycle:", ", ".join(comp))
    for a, b, rule in upward(found):
        print(f"{_where(found, a, b)}: {rule}" + ("  [allowed]" if (a, b) in ALLOWED else ""))
    sys.exit(0)
