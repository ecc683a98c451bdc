"""What the command line does with a store: ``add``, and ``run`` / ``eval`` / ``export`` / ``info`` on one.

:mod:`graphseg.cli` parses and prints; these functions do the work and
return what to print, so the same steps are one call from Python too.

Examples
--------
>>> import tempfile, os
>>> from graphseg.testing.scenes import box_scene, TWO_BOXES
>>> d = tempfile.mkdtemp()
>>> sg, report = add_views(os.path.join(d, "s"), [box_scene(TWO_BOXES, views=2, shape=(48, 64))])
>>> report_lines(report)[0]
'added 2 views (000, 001) to generation 1: 2 objects'
>>> info_lines(os.path.join(d, "s"))[1]
'  format: graphseg-store version 1; generation 1'
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..config import Config
from ..result import Result
from ..scene import Scene, SceneError
from .layout import StoreError, is_store, read_pointer
from .scenegraph import AddReport, SceneGraph

__all__ = ["add_views", "report_lines", "event_line", "info_lines", "store_output", "store_metrics", "store_result", "read_candidates", "suggest_lines", "zero_score_note", "is_store"]


def add_views(
    store: str | os.PathLike[str],
    inputs: Sequence[Any],
    config: Config | None = None,
    *,
    segmenter: Any = None,
    matcher: Any = None,
    lifter: Any = None,
    select: dict[str, Any] | None = None,
    progress: bool = False,
) -> tuple[SceneGraph, AddReport]:
    """Open (or create) ``store`` and add the views of ``inputs`` (scene folders, image files, scenes).

    ``config`` is used to create a new store; for an existing one it must be
    None or the store's own. Inputs are checked before the store is created,
    so a bad input leaves no empty store behind.

    Raises
    ------
    SceneError
        One line for a missing input, an input inside the store, a store that
        is locked, refused or of an unknown format version.
    """
    paths = [x for x in inputs if isinstance(x, (str, os.PathLike))]
    for p in paths:
        if not os.path.exists(p):
            raise SceneError("no such file or folder", where=str(p), field="input")
        if Path(os.path.abspath(p)).resolve().is_relative_to(Path(os.path.abspath(store)).resolve()):
            raise SceneError(f"lies inside the store {store}", where=str(p), field="input")
    from .scenegraph import _as_views

    views, objects, _ = _as_views(list(inputs), **(select or {}))  # read first: a bad input leaves no empty store behind
    created = not os.path.lexists(store)
    sg = SceneGraph.open(store, config, inputs=paths)
    try:
        return sg, sg.add(Scene(views, objects, sg.name), segmenter=segmenter, matcher=matcher, lifter=lifter, progress=progress)
    except BaseException:
        if created:
            _remove_empty_store(sg.root)
        raise


def _remove_empty_store(root: Path) -> None:
    """Remove a store this command created when its first add failed (generation 0, only the store's own files)."""
    import re
    import shutil

    from .layout import LOCK, POINTER

    try:
        if read_pointer(root)["generation"] != 0:
            return
    except SceneError:
        return
    ours = re.compile(r"^(\.graphseg-output|" + re.escape(POINTER) + "|" + re.escape(LOCK) + r"|views|pairs|generations|generations/000000\.state\.json)$")
    for p in root.rglob("*"):
        if p.is_symlink() or not ours.match(p.relative_to(root).as_posix()):
            return  # something else is in there: keep it all
    shutil.rmtree(root, ignore_errors=True)


def event_line(event: dict[str, Any]) -> str:
    """One line for an event of :mod:`graphseg.store.ids`.

    Examples
    --------
    >>> event_line({"event": "merge", "id": 2, "ids": [2, 5], "edges": [{"stage": 0, "criterion": "pixel_match", "weight": 0.4, "u": [["000", 1]], "v": [["003", 2]]}]})
    'merged objects 2, 5 into 2: stage 0 pixel_match 000:1 - 003:2 (weight 0.4)'
    """
    kind = event["event"]
    if kind == "new":
        return f"new object {event['id']}"
    if kind == "dropped":
        return f"object {event['id']} dropped (below the minimum support)"
    edges = event.get("edges")
    why = event.get("reason", "")
    if edges:
        parts = []
        for e in edges[:3]:
            u = ",".join(f"{v}:{m}" for v, m in e["u"][:2]) + ("..." if len(e["u"]) > 2 or e.get("u_more") else "")
            w = ",".join(f"{v}:{m}" for v, m in e["v"][:2]) + ("..." if len(e["v"]) > 2 or e.get("v_more") else "")
            ev = f" (weight {e['weight']:.3g})" if "weight" in e else ""
            parts.append(f"stage {e.get('stage', '?')} {e.get('criterion', '?')} {u} - {w}{ev}")
        why = "; ".join(parts) + (f"; and {len(edges) - 3} more edges" if len(edges) > 3 else "")
    if kind == "merge":
        return f"merged objects {', '.join(map(str, event['ids']))} into {event['id']}: {why}"
    return f"split object {event['id']} into {', '.join(map(str, event['into']))}: {why}"


def report_lines(report: AddReport) -> list[str]:
    """What ``graphseg add`` prints: one line for the add, one per merge or split.

    New objects are counted, not listed one by one.
    """
    lines = []
    if report.added:
        shown = ", ".join(report.added[:6]) + (" ..." if len(report.added) > 6 else "")
        lines.append(f"added {len(report.added)} view{'s' if len(report.added) != 1 else ''} ({shown}) to generation {report.generation}: {report.num_objects} objects")
    else:
        lines.append(f"nothing added (generation {report.generation}, {report.num_objects} objects)")
    new = [e["id"] for e in report.events if e["event"] == "new"]
    if new and len(new) != report.num_objects:
        lines.append(f"new objects: {', '.join(map(str, new))}")
    for e in report.events:
        if e["event"] in ("merge", "split", "dropped"):
            lines.append(event_line(e))
    if report.replaced:
        lines.append(f"lifted again (their points changed): {', '.join(report.replaced)}")
    return lines


def info_lines(path: str | os.PathLike[str]) -> list[str]:
    """What ``graphseg info STORE`` prints."""
    sg = SceneGraph.open(path, create=False)
    pointer = read_pointer(sg.root)
    names = sg.view_names
    lines = [f"graphseg store: {path}", f"  format: {pointer['format']} version {pointer['version']}; generation {sg.generation}"]
    lines.append(f"  views: {len(names)}" + (f" ({', '.join(names[:8])}{' ...' if len(names) > 8 else ''})" if names else ""))
    lines.append(f"  lifter: {sg.lifter or '-'}; stages: {' -> '.join('+'.join(s) for s in sg.config.stage_names())}; contractor: {sg.config.contractor.name}")
    if not names:
        return lines
    r = sg.result()
    lines.append(f"  objects: {r.num_objects} (ids {', '.join(map(str, sg.object_ids))})")
    lines.append(f"  masks: {len(r.mask_object)}; view pairs matched: {len(sg.pairs)}")
    for s, g in enumerate(r.graphs):
        lines.append(f"  stage {s}: {g.num_nodes} nodes, {g.num_edges} edges")
    for h in sg.history[-3:]:
        changes = [event_line(e) for e in h["events"] if e["event"] in ("merge", "split", "dropped")]
        lines.append(f"  generation {h['generation']}: added {', '.join(h['added'][:6])}{' ...' if len(h['added']) > 6 else ''}" + (f"; {'; '.join(changes)}" if changes else ""))
    return lines


def store_result(path: str | os.PathLike[str]) -> Result:
    """The current result of the store at ``path``."""
    return SceneGraph.open(path, create=False).result()


def store_output(path: str | os.PathLike[str]) -> tuple[Result, Scene, dict[str, Any], dict[str, Any] | None]:
    """What ``graphseg run STORE -o OUT`` writes: the result, the stored scene, ``run.json`` entries and metrics."""
    from ..job import evaluate_scene

    sg = SceneGraph.open(path, create=False)
    result = sg.result()
    scene = sg.scene()
    metrics = evaluate_scene(result, scene)
    if metrics is not None:
        from ..audit import audit

        metrics["audit"] = audit(result, scene)
    info = {"scene": str(Path(path).resolve()), "format": "store", "store": {"generation": sg.generation, "object_ids": sg.object_ids}}
    return result, scene, info, metrics


def store_metrics(path: str | os.PathLike[str], scene: Any = None, *, audit: bool = False) -> dict[str, Any]:
    """Metrics of a store's result against ground truth: the stored views' own, or those of ``scene``.

    Raises
    ------
    SceneError
        When neither the stored views nor ``scene`` have ground truth, or the
        scene lacks a view of the store.
    """
    from ..job import evaluate_scene

    sg = SceneGraph.open(path, create=False)
    result = sg.result()
    if scene is None:
        sc = sg.scene()
        where = str(path)
    else:
        from ..io import detect_format, load_scene

        where = str(scene)
        gt = scene if isinstance(scene, Scene) else load_scene(scene, format=detect_format(scene))
        names = [v.name for v in gt.views]
        missing = [n for n in result.view_names if n not in names]
        if missing:
            raise SceneError(f"the scene has no view {missing[0]!r} of the store", where=where, field="views")
        stored = sg.scene()
        sc = Scene([v.replace(instances=gt.views[names.index(v.name)].instances) for v in stored.views], dict(gt.objects), stored.name, dict(stored.meta))
    if not sc.has_instances:
        raise StoreError("the store's views have no ground truth; pass --scene", where=where, field="instances")
    metrics = evaluate_scene(result, sc)
    assert metrics is not None
    if audit:
        from ..audit import audit as edge_audit

        metrics["audit"] = edge_audit(result, sc)
    return metrics


def read_candidates(path: str | os.PathLike[str]) -> Any:
    """Candidate ``cam_to_world`` poses ``[C, 4, 4]`` from a ``.npy`` file or a JSON file.

    JSON: a list of 4x4 matrices, or ``{"cam_to_world": [...]}``.

    Raises
    ------
    SceneError
        One line naming the file and what is wrong.
    """
    import numpy as np

    from ..io.files import read_json, read_npy

    p = Path(path)
    where = str(p)
    if not p.is_file():
        raise SceneError("file not found", where=where, field="candidates")
    if p.suffix == ".npy":
        arr = read_npy(p, field="candidates")
    else:
        doc = read_json(p, field="candidates", what="unreadable")
        if isinstance(doc, dict):
            doc = doc.get("cam_to_world")
        try:
            arr = np.asarray(doc, np.float64)
        except (ValueError, TypeError, OverflowError) as err:
            raise SceneError(f"unreadable ({(str(err).splitlines() or [''])[0]})", where=where, field="candidates") from err
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1:] != (4, 4) or arr.dtype.kind not in "fiu" or not np.isfinite(arr).all():
        raise SceneError(f"expected finite cam_to_world poses [C, 4, 4] (got {arr.dtype} {list(arr.shape)})", where=where, field="candidates")
    return arr.astype(np.float64)


def suggest_lines(store: str | os.PathLike[str], candidates: str | os.PathLike[str] | None = None, *, top: int = 5, seed: Any = None) -> list[str]:
    """What ``graphseg suggest STORE`` prints: the ``top`` candidate poses, best first.

    Columns: the score, its terms (each normalised over the candidates), the
    ``spread`` (degrees from the nearest camera of the store, the order among
    equal scores) and the camera position. When every score is 0, a last line
    says why (:func:`zero_score_note`).
    """
    import numpy as np

    from ..nbv import suggest_views

    poses = read_candidates(candidates) if candidates is not None else None
    sg = SceneGraph.open(store, create=False)
    scene, result = sg.scene(), sg.result()
    try:
        ranked = suggest_views(scene, result, poses, seed=seed)  # what sg.suggest does, with the scene kept for the note
    except ValueError as err:
        if isinstance(err, SceneError):
            raise
        raise SceneError((str(err).splitlines() or [""])[0], where=str(candidates or store), field="candidates") from err
    lines = [f"{'rank':>4} {'cand':>5} {'score':>7}  {'ambiguity':>9} {'under_seen':>10} {'table':>6} {'spread':>6}  camera position (x, y, z)"]
    for r, v in enumerate(ranked[: max(1, int(top))], 1):
        x, y, z = np.asarray(v.cam_to_world)[:3, 3]
        t = v.terms
        lines.append(
            f"{r:>4} {v.index:>5} {v.score:>7.3f}  {t.get('ambiguity', 0):>9.3f} {t.get('under_seen', 0):>10.3f} {t.get('table', 0):>6.3f} {v.spread:>6.1f}  ({x:.3f}, {y:.3f}, {z:.3f})"
        )
    if ranked and all(v.score == 0 for v in ranked):
        lines.append(zero_score_note(scene, result))
    return lines


def zero_score_note(scene: Scene, result: Result, weights: dict[str, float] | None = None) -> str:
    """Why every candidate scores 0, in one line (``graphseg suggest`` prints it under the table).

    The score is the weighted sum of the terms (:data:`graphseg.nbv.DEFAULT_WEIGHTS`:
    ``under_seen`` alone, chosen on ``benchmarks/bench_nbv.py``), so it is 0 when
    the weighted terms are: with the default weights, when every object is seen
    in two or more views and no fragment was dropped (the usual case once a few
    views are in), or when no candidate sees what is under-seen. The other
    terms are printed but weigh 0. Equal scores rank by ``spread``.

    Examples
    --------
    >>> from graphseg.method.segment import segment
    >>> from graphseg.testing.scenes import two_boxes_scene
    >>> scene, masks, matches = two_boxes_scene()
    >>> print(zero_score_note(scene, segment(scene, masks, matches)))
    all scores are 0: every object is seen in two or more views, so nothing is under-seen (the score counts under_seen only; ambiguity and table are shown but weigh 0); the candidates rank by spread, the angle in degrees to the nearest camera, largest first
    """
    from ..nbv import DEFAULT_WEIGHTS, TERMS, under_seen_targets

    w = {**DEFAULT_WEIGHTS, **(weights or {})}
    weighted = [t for t in TERMS if w.get(t, 0) > 0]
    shown = [t for t in TERMS if t not in weighted]
    if not weighted:
        why = "every term weighs 0"
    elif weighted == ["under_seen"]:
        why = "no candidate sees the objects seen in fewer than two views" if under_seen_targets(scene, result) else "every object is seen in two or more views, so nothing is under-seen"
    else:
        why = f"{' and '.join(weighted)} {'is' if len(weighted) == 1 else 'are'} 0 for every candidate"
    counts = f"the score counts {', '.join(weighted)} only" if weighted else "the score counts nothing"
    also = f"; {' and '.join(shown)} {'is' if len(shown) == 1 else 'are'} shown but weigh{'s' if len(shown) == 1 else ''} 0" if shown and weighted else ""
    return f"all scores are 0: {why} ({counts}{also}); the candidates rank by spread, the angle in degrees to the nearest camera, largest first"
