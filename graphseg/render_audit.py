"""Rendering of an edge audit (:func:`graphseg.audit.audit`): plain text for the terminal, HTML for the report.

:mod:`graphseg.audit` computes the audit and returns plain data (dicts, lists,
numbers); this module only formats that data, so the report page and the
command line render an audit without importing the method.

Examples
--------
>>> print(format_by_criterion({"pixel_match": 2}))
pixel_match: 2
"""

from __future__ import annotations

from typing import Any

__all__ = ["format_audit", "format_by_criterion", "audit_html"]


def format_by_criterion(by: Any, empty: str = "") -> str:
    """The wrong edges per criterion as text: ``pixel_match: 3, chamfer_3d: 1`` (``empty`` when there are none).

    Examples
    --------
    >>> format_by_criterion({"pixel_match": 3, "chamfer_3d": 1})
    'pixel_match: 3, chamfer_3d: 1'
    >>> format_by_criterion({}, empty="-")
    '-'
    """
    if not isinstance(by, dict) or not by:
        return empty
    return ", ".join(f"{k}: {v}" for k, v in by.items())


def format_audit(report: dict[str, Any], *, max_cut: int = 5) -> str:
    """Plain-text summary of :func:`audit` for the terminal.

    Examples
    --------
    >>> print(format_audit({"summary": {"masks": 3, "impure_masks": 0, "edges": [2], "wrong_edges": [1], "merge_errors": 0, "cut_edges": 0},
    ...                     "stages": [{"stage": 0, "edges": 2, "wrong": 1, "wrong_by_criterion": {"pixel_match": 1}}], "merge_errors": []}))
    audit: 3 masks, 0 impure; 0 merge errors
      stage 0: 1 of 2 edges join different objects (pixel_match: 1)
    """
    s = report["summary"]
    lines = [f"audit: {s['masks']} masks, {s['impure_masks']} impure; {s['merge_errors']} merge errors"]
    if s.get("majority_grouping_iou") is not None:
        lines.append(f"  each mask to its majority object (a perfect graph): mean IoU {s['majority_grouping_iou']:.3f}")
    for st in report["stages"]:
        by = format_by_criterion(st.get("wrong_by_criterion"))
        lines.append(f"  stage {st['stage']}: {st['wrong']} of {st['edges']} edges join different objects" + (f" ({by})" if by else ""))
    for me in report["merge_errors"]:
        cut = "; ".join(f"s{c['stage']} {c['criterion']} v{c['views'][0]}:{c['mask_ids'][0]}-v{c['views'][1]}:{c['mask_ids'][1]}" for c in me["cut"][:max_cut])
        more = f" (+{len(me['cut']) - max_cut})" if len(me["cut"]) > max_cut else ""
        lines.append(f"  object {me['object']} merges {me['gt'][0]} and {me['gt'][1]}: cut {len(me['cut'])} edges: {cut}{more}")
    return "\n".join(lines)


def audit_html(report: dict[str, Any]) -> str:
    """An HTML section (``<h2>Edge audit</h2>`` ...) for the report page.

    Examples
    --------
    >>> audit_html({"summary": {"masks": 1, "impure_masks": 0, "edges": [], "wrong_edges": [], "merge_errors": 0, "cut_edges": 0},
    ...             "stages": [], "merge_errors": [], "impure_masks": []}).startswith("<h2>Edge audit</h2>")
    True
    """
    import html

    s = report["summary"]
    rows = "".join(
        f"<tr><td>{st['stage']}</td><td>{st['edges']}</td><td>{st['wrong']}</td><td>{html.escape(format_by_criterion(st.get('wrong_by_criterion'), empty='-'))}</td></tr>" for st in report["stages"]
    )
    merges = "".join(
        f"<li>object {me['object']} merges {html.escape(str(me['gt'][0]))} and {html.escape(str(me['gt'][1]))}: "
        f"{len(me['cut'])} edges would split them: "
        + html.escape("; ".join(f"stage {c['stage']} {c['criterion']} view {c['views'][0]} mask {c['mask_ids'][0]} - view {c['views'][1]} mask {c['mask_ids'][1]}" for c in me["cut"]))
        + "</li>"
        for me in report["merge_errors"]
    )
    return (
        "<h2>Edge audit</h2>"
        f"<p>{s['masks']} masks, {s['impure_masks']} impure (under {int(100 * report.get('purity', 0.8))}% one object); {s['merge_errors']} merge errors."
        + (f" With each mask given to its majority object (a perfect graph) the mean IoU is {s['majority_grouping_iou']:.3f}." if s.get("majority_grouping_iou") is not None else "")
        + "</p>"
        f"<table><tr><th>stage</th><th>edges</th><th>wrong</th><th>by criterion</th></tr>{rows}</table>"
        + (f"<ul>{merges}</ul>" if merges else "")
    )
