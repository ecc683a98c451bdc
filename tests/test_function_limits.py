"""Small functions (issue 53): in ``method/``, ``store/``, ``job`` and ``pipeline`` no function's body
is over 80 lines, and outside the backends' constructors no function takes more than 10 parameters.

The body is counted from the first statement after the docstring to the last line (numpydoc
docstrings with their doctests are required and are not code). Every module of ``graphseg/`` is
parsed with ``ast``; nothing is imported. ``ALLOWED`` lists the functions still over a limit, each
with its count; it may only shrink: :func:`test_allowed_entries_are_still_over` fails once one is
fixed, and a function that grows past its recorded count fails too.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "graphseg"
MAX_LINES = 80
MAX_PARAMS = 10
LINE_SCOPE = ("method/", "store/", "job.py", "pipeline.py")

#: ("path:function", "lines" | "params") -> the count today: the functions still to split or to give an options object.
ALLOWED: dict[tuple[str, str], int] = {
    ("backends/lifters/sfm.py:_map", "params"): 17,
    ("backends/lifters/sfm.py:_run_sfm", "params"): 14,
    ("backends/lifters/sfm.py:run_sfm", "params"): 13,
    ("backends/lifters/stereo.py:pair_points", "params"): 13,
    ("backends/segmenters/automask.py:_crop_proposals", "params"): 11,
    ("backends/segmenters/automask.py:generate_masks", "params"): 15,
    ("backends/segmenters/geometric.py:geometric_segments", "params"): 15,
    ("batch/__init__.py:run_batch", "params"): 11,
    ("graphs/adjacency.py:smooth_adjacency_links", "params"): 12,
    ("graphs/repulsion.py:boundary_separation", "params"): 11,
    ("graphs/repulsion.py:depth_jump_cannot_links", "params"): 11,
    ("job.py:run_job", "params"): 15,
    ("method/segment.py:apply_min_support", "params"): 11,
    ("method/split.py:merge_objects", "params"): 11,
    ("method/split.py:split_objects", "params"): 15,
    ("sim/pybullet_scenes.py:synthesize", "params"): 14,
    ("store/scenegraph.py:SceneGraph._add", "lines"): 227,
}


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


def test_no_new_function_over_the_limits():
    over = measure()
    new = {k: v for k, v in over.items() if k not in ALLOWED}
    grown = {k: (ALLOWED[k], v) for k, v in over.items() if k in ALLOWED and v > ALLOWED[k]}
    assert not new, f"over {MAX_LINES} lines or {MAX_PARAMS} parameters: {new}"
    assert not grown, f"grew past the recorded count (recorded, now): {grown}"


def test_allowed_entries_are_still_over():
    over = measure()
    fixed = [k for k in ALLOWED if k not in over]
    assert not fixed, f"now within the limits: remove from ALLOWED: {fixed}"
