"""Small functions (issue 53): in ``method/``, ``store/``, ``job`` and ``pipeline`` no function's body
is over 80 lines, and outside the backends' constructors no function takes more than 10 parameters.

The body is counted from the first statement after the docstring to the last line (numpydoc
docstrings with their doctests are required and are not code). Every module of ``graphseg/`` is
parsed with ``ast``; nothing is imported. There is no allow-list: a function over a limit takes a
config section or an options object (``SplitConfig``, ``SfmRun``, ``CameraRig``, a criterion's
``Options``), or is split into steps (``SceneGraph._add``).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "graphseg"
MAX_LINES = 80
MAX_PARAMS = 10
LINE_SCOPE = ("method/", "store/", "job.py", "pipeline.py")

def _functions(tree: ast.AST, prefix: str = ""):
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield f"{prefix}{node.name}", node
            yield from _functions(node, f"{prefix}{node.name}.")
        elif isinstance(node, ast.ClassDef):
            yield from _functions(node, f"{prefix}{node.name}.")


def body_lines(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines from the first statement after the docstring to the end of the function."""
    body = fn.body
    if body and isinstance(body[0], ast.Expr) and isinstance(getattr(body[0], "value", None), ast.Constant) and isinstance(body[0].value.value, str):
        body = body[1:]
    return 0 if not body else int(fn.end_lineno) - body[0].lineno + 1  # type: ignore[arg-type]


def params(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = fn.args
    names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)] + [x.arg for x in (a.vararg, a.kwarg) if x is not None]
    return len([n for n in names if n not in ("self", "cls")])


def measure() -> dict[tuple[str, str], int]:
    over: dict[tuple[str, str], int] = {}
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        for name, fn in _functions(ast.parse(path.read_text())):
            key = f"{rel}:{name}"
            if rel.startswith(LINE_SCOPE) and body_lines(fn) > MAX_LINES:
                over[(key, "lines")] = body_lines(fn)
            backend_constructor = rel.startswith("backends/") and name.endswith("__init__")
            if not backend_constructor and params(fn) > MAX_PARAMS:
                over[(key, "params")] = params(fn)
    return over


def test_body_lines_and_parameters_by_hand():
    fn = ast.parse('def f(a, b, *c, d=1, **e):\n    """Doc.\n\n    More."""\n    x = 1\n    return x\n').body[0]
    assert body_lines(fn) == 2 and params(fn) == 5
    method = ast.parse("class A:\n    def g(self, a):\n        pass\n").body[0].body[0]
    assert params(method) == 1 and body_lines(method) == 1


def test_no_function_over_the_limits():
    over = measure()
    assert not over, f"over {MAX_LINES} lines or {MAX_PARAMS} parameters: {over}"


def test_the_check_sees_a_function_over_each_limit(tmp_path, monkeypatch):
    pkg = tmp_path / "graphseg"
    (pkg / "method").mkdir(parents=True)
    (pkg / "method" / "long.py").write_text("def f():\n" + "    x = 1\n" * 81)
    (pkg / "wide.py").write_text("def g(" + ", ".join(f"a{i}" for i in range(11)) + "):\n    pass\n")
    (pkg / "backends").mkdir()
    (pkg / "backends" / "b.py").write_text("class B:\n    def __init__(self, " + ", ".join(f"a{i}" for i in range(11)) + "):\n        pass\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", pkg)
    assert measure() == {("method/long.py:f", "lines"): 81, ("wide.py:g", "params"): 11}  # a backend constructor may take more
