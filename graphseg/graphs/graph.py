"""The correspondence graph: masks as nodes, "same object" evidence as edges.

Storage is array-first, in PyG's names:

* ``edge_index``: int64 ``[2, E]``; column ``e`` joins ``edge_index[0, e]`` and
  ``edge_index[1, e]``. Edges are undirected; adders store ``u < v``.
* ``edge_attr``: dict of columns, each of length ``E`` (``criterion`` is a str
  column; ``weight`` float64; ``stage`` int64; evidence such as ``count``).
* ``node_attr``: a columnar node table, each column of length ``num_nodes``
  (``[N]`` or ``[N, k]``).
* ``masks``: optional per-view int32 label images ``[H, W]`` whose value is
  ``mask_id + 1`` of that view (``0`` = no mask), so a saved graph can be
  contracted again without re-running any backend.
* ``members``: which base mask ``(view, mask_id)`` belongs to which node. For a
  mask-level graph this is the identity; :func:`~graphseg.graphs.coarsen`
  composes it with the cluster vector.

Mask-level node columns (:class:`MaskNode`): ``view``, ``mask_id``, ``area``,
``bbox`` (``[N, 4]`` as x_min, y_min, x_max, y_max, inclusive), ``centroid``
(``[N, 2]`` as x, y) and optionally ``num_points``, ``centroid_3d`` (``[N, 3]``)
and ``bbox_3d`` (``[N, 6]`` as min xyz, max xyz). Super-node columns
(:class:`SuperNode`): ``component``, ``member_count``, ``area`` plus whatever
:func:`~graphseg.graphs.coarsen` aggregated.

Examples
--------
>>> import numpy as np
>>> g = CorrespondenceGraph(3, edge_index=np.array([[0], [1]]),
...                         edge_attr={"criterion": np.array(["pixel_match"]),
...                                    "weight": np.array([0.5])})
>>> g
CorrespondenceGraph(level='mask', num_nodes=3, num_edges=1, node_attr=[], edge_attr=['criterion', 'weight'])
>>> g.validate()
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .edge_index import GraphValidationError, as_edge_index

__all__ = [
    "CorrespondenceGraph",
    "MaskNode",
    "SuperNode",
    "GraphValidationError",
    "as_edge_index",
    "fill_value",
    "concat_edge_attr",
    "mask_node_table",
]


@dataclass(frozen=True)
class MaskNode:
    """One 2D mask of one view (a row of a mask-level node table)."""

    view: int
    mask_id: int
    area: int
    bbox: tuple[int, int, int, int]
    centroid: tuple[float, float]
    num_points: int | None = None
    centroid_3d: tuple[float, float, float] | None = None
    bbox_3d: tuple[float, float, float, float, float, float] | None = None


@dataclass(frozen=True)
class SuperNode:
    """A contracted component: a set of masks believed to show one object."""

    component: int
    member_count: int
    area: int
    extra: dict[str, Any] = field(default_factory=dict)


def fill_value(dtype: np.dtype) -> Any:
    """The value used for a column an edge or node does not have.

    NaN for floats, -1 for integers, ``""`` for strings, False for booleans.
    """
    if dtype.kind == "f":
        return np.nan
    if dtype.kind in "iu":
        return -1
    if dtype.kind == "b":
        return False
    return ""


def concat_edge_attr(parts: Sequence[tuple[int, Mapping[str, np.ndarray]]]) -> dict[str, np.ndarray]:
    """Concatenate edge-attribute column sets, filling columns a part lacks.

    Parameters
    ----------
    parts : sequence of (num_edges, columns)
        Each part's edge count and its columns.

    Returns
    -------
    dict
        Columns of length ``sum(num_edges)``.

    Examples
    --------
    >>> out = concat_edge_attr([(1, {"weight": np.array([0.5])}),
    ...                         (2, {"count": np.array([3, 4])})])
    >>> out["weight"].tolist(), out["count"].tolist()
    ([0.5, nan, nan], [-1, 3, 4])
    """
    names: dict[str, np.dtype] = {}
    for _, cols in parts:
        for name, col in cols.items():
            col = np.asarray(col)
            if name in names:
                names[name] = np.result_type(names[name], col.dtype)
            else:
                names[name] = col.dtype
    out: dict[str, np.ndarray] = {}
    for name, dtype in names.items():
        chunks = []
        for n, cols in parts:
            if name in cols:
                chunks.append(np.asarray(cols[name]).astype(dtype, copy=False))
            else:
                chunks.append(np.full(n, fill_value(dtype), dtype=dtype))
        out[name] = np.concatenate(chunks) if chunks else np.zeros(0, dtype=dtype)
    return out


def mask_node_table(
    labels: Sequence[np.ndarray], points: Sequence[np.ndarray | None] | None = None
) -> dict[str, np.ndarray]:
    """Build the mask-level node table from per-view label images.

    Parameters
    ----------
    labels : sequence of int arrays ``[H, W]``
        Per view, ``mask_id + 1`` per pixel, 0 where no mask.
    points : sequence of float arrays ``[H, W, 3]`` or None, optional
        World points per pixel (NaN = invalid); adds the 3D columns.

    Returns
    -------
    dict
        Columns ``view``, ``mask_id``, ``area``, ``bbox``, ``centroid`` and, with
        points, ``num_points``, ``centroid_3d``, ``bbox_3d``. Nodes are ordered by
        view, then mask id; only masks with at least one pixel appear.

    Notes
    -----
    One ``bincount`` and one stable (radix) sort of the pixels by label per view,
    then ``reduceat`` segment reductions: O(H W) per view, no scatter.

    Examples
    --------
    >>> lab = np.array([[1, 1, 0], [0, 2, 2]])
    >>> t = mask_node_table([lab])
    >>> t["mask_id"].tolist(), t["area"].tolist(), t["bbox"].tolist()
    ([0, 1], [2, 2], [[0, 0, 1, 0], [1, 1, 2, 1]])
    """
    cols: dict[str, list[np.ndarray]] = {k: [] for k in ("view", "mask_id", "area", "bbox", "centroid")}
    with_3d = points is not None and any(p is not None for p in points)
    if with_3d:
        for k in ("num_points", "centroid_3d", "bbox_3d"):
            cols[k] = []
    for v, lab in enumerate(labels):
        lab = np.asarray(lab)
        h, w = lab.shape
        flat = lab.reshape(-1)
        if flat.size and flat.dtype.kind in "iu" and 0 <= flat.min() and flat.max() < 2**16:
            # counts by bincount, then one stable radix sort of the whole image by label:
            # the unlabelled pixels come first, then each mask's pixels in raster order
            cnt = np.bincount(flat)
            present = np.flatnonzero(cnt[1:])
            area = cnt[1:][present]
            starts = np.zeros(present.size, np.int64)
            starts[1:] = np.cumsum(area)[:-1]
            ends = starts + area
            pix = np.argsort(flat.astype(np.uint16), kind="stable")[int(cnt[0]) :]
        else:
            nz = np.flatnonzero(flat)
            ids = flat[nz].astype(np.int64) - 1
            # one stable sort by mask id; pixels stay in raster order per mask
            order = np.argsort(ids, kind="stable")
            sid = ids[order]
            starts = np.flatnonzero(np.r_[True, sid[1:] != sid[:-1]]) if sid.size else np.zeros(0, np.int64)
            ends = np.r_[starts[1:], sid.size]
            present = sid[starts] if sid.size else np.zeros(0, np.int64)
            area = ends - starts
            pix = nz[order]
        ys, xs = np.divmod(pix, w)
        if present.size:
            x0 = np.minimum.reduceat(xs, starts)
            x1 = np.maximum.reduceat(xs, starts)
            y0, y1 = ys[starts], ys[ends - 1]  # raster order: first and last rows
            cx = np.add.reduceat(xs, starts) / area
            cy = np.add.reduceat(ys, starts) / area
        else:
            x0 = x1 = y0 = y1 = np.zeros(0, np.int64)
            cx = cy = np.zeros(0)
        cols["view"].append(np.full(present.size, v, np.int64))
        cols["mask_id"].append(present.astype(np.int64))
        cols["area"].append(area.astype(np.int64))
        cols["bbox"].append(np.stack([x0, y0, x1, y1], 1).astype(np.int64))
        cols["centroid"].append(np.stack([cx, cy], 1).astype(np.float64))
        if with_3d:
            pts = None if points is None else points[v]
            if pts is None:
                cols["num_points"].append(np.zeros(present.size, np.int64))
                cols["centroid_3d"].append(np.full((present.size, 3), np.nan))
                cols["bbox_3d"].append(np.full((present.size, 6), np.nan))
                continue
            pts = np.asarray(pts)
            # contiguous per-coordinate gathers (1D takes and SIMD tests beat [P, 3] row ops);
            # the reductions below give the same values as on the [P, 3] array
            pc = [pts[..., k].reshape(-1)[pix] for k in range(3)]
            all_ok = bool(np.isfinite(pts).all())  # one flat SIMD pass; per pixel only when needed
            if not all_ok:
                ok = np.isfinite(pc[0])
                ok &= np.isfinite(pc[1])
                ok &= np.isfinite(pc[2])
                all_ok = bool(ok.all())
            if present.size:
                cnt = area.copy() if all_ok else np.add.reduceat(ok.astype(np.int64), starts)
                if all_ok:
                    p64 = [c.astype(np.float64) for c in pc]
                    pn = pc
                else:
                    p64 = [np.where(ok, c, 0).astype(np.float64) for c in pc]
                    pn = [np.where(ok, c, np.nan) for c in pc]  # min/max are exact in the input dtype
                with np.errstate(invalid="ignore", divide="ignore"):
                    c3 = np.stack([np.add.reduceat(c, starts) for c in p64], 1) / cnt[:, None]
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    box = np.stack([np.fmin.reduceat(c, starts) for c in pn] + [np.fmax.reduceat(c, starts) for c in pn], 1).astype(np.float64)
                box[cnt == 0] = np.nan
                c3[cnt == 0] = np.nan
            else:
                cnt, c3, box = np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 6))
            cols["num_points"].append(cnt.astype(np.int64))
            cols["centroid_3d"].append(c3)
            cols["bbox_3d"].append(box)
    shapes = {"bbox": (0, 4), "centroid": (0, 2), "centroid_3d": (0, 3), "bbox_3d": (0, 6)}
    out = {}
    for k, parts in cols.items():
        if parts:
            out[k] = np.concatenate(parts)
        else:
            out[k] = np.zeros(shapes.get(k, (0,)), np.float64 if k in ("centroid", "centroid_3d", "bbox_3d") else np.int64)
    return out


class CorrespondenceGraph:
    """An array-first correspondence graph between image masks.

    Parameters
    ----------
    num_nodes : int
        Number of nodes ``N``.
    edge_index : array_like, optional
        int64 ``[2, E]``.
    edge_attr : mapping of str to array, optional
        Columns of length ``E``.
    node_attr : mapping of str to array, optional
        Columns of length ``N`` (``[N]`` or ``[N, k]``).
    masks : sequence of int arrays ``[H, W]``, optional
        Per-view label images, ``mask_id + 1`` per pixel.
    members : mapping with ``view``, ``mask_id``, ``node`` arrays, optional
        Base mask -> node map; defaults to the identity for mask-level graphs.
    level : {"mask", "super"}
        Whether nodes are masks or contracted components.
    meta : mapping, optional
        Graph-level scalar attributes.

    Notes
    -----
    Methods never mutate the graph unless they take ``in_place=True``.
    """

    def __init__(
        self,
        num_nodes: int,
        edge_index: Any = None,
        edge_attr: Mapping[str, Any] | None = None,
        node_attr: Mapping[str, Any] | None = None,
        masks: Sequence[np.ndarray] | None = None,
        members: Mapping[str, Any] | None = None,
        level: str = "mask",
        meta: Mapping[str, Any] | None = None,
    ) -> None:
        self.num_nodes = int(num_nodes)
        self.edge_index = as_edge_index(np.zeros((2, 0), np.int64) if edge_index is None else edge_index)
        self.edge_attr: dict[str, np.ndarray] = {k: np.asarray(v) for k, v in (edge_attr or {}).items()}
        self.node_attr: dict[str, np.ndarray] = {k: np.asarray(v) for k, v in (node_attr or {}).items()}
        self.masks: list[np.ndarray] | None = None if masks is None else [np.asarray(m) for m in masks]
        self.level = level
        self.meta: dict[str, Any] = dict(meta or {})
        self._members = None if members is None else {k: np.asarray(v, dtype=np.int64) for k, v in members.items()}

    # ------------------------------------------------------------------ basics
    @property
    def num_edges(self) -> int:
        """Number of edges ``E``."""
        return int(self.edge_index.shape[1])

    def __repr__(self) -> str:
        return (
            f"CorrespondenceGraph(level={self.level!r}, num_nodes={self.num_nodes}, "
            f"num_edges={self.num_edges}, node_attr={list(self.node_attr)}, "
            f"edge_attr={list(self.edge_attr)})"
        )

    @classmethod
    def from_masks(
        cls,
        labels: Sequence[np.ndarray],
        points: Sequence[np.ndarray | None] | None = None,
        **kwargs: Any,
    ) -> CorrespondenceGraph:
        """A mask-level graph with no edges from per-view label images.

        Examples
        --------
        >>> g = CorrespondenceGraph.from_masks([np.array([[1, 2], [0, 2]])])
        >>> g.num_nodes, g.node_attr["area"].tolist()
        (2, [1, 2])
        """
        table = mask_node_table(labels, points)
        return cls(len(table["view"]), node_attr=table, masks=labels, **kwargs)

    @property
    def members(self) -> dict[str, np.ndarray]:
        """Base masks and their node: ``{"view": [M], "mask_id": [M], "node": [M]}``."""
        if self._members is not None:
            return self._members
        if "view" in self.node_attr and "mask_id" in self.node_attr:
            return {
                "view": self.node_attr["view"].astype(np.int64),
                "mask_id": self.node_attr["mask_id"].astype(np.int64),
                "node": np.arange(self.num_nodes, dtype=np.int64),
            }
        return {k: np.zeros(0, np.int64) for k in ("view", "mask_id", "node")}

    def copy(self) -> CorrespondenceGraph:
        """A deep copy (arrays copied, masks shared read-only)."""
        return CorrespondenceGraph(
            self.num_nodes,
            self.edge_index.copy(),
            {k: v.copy() for k, v in self.edge_attr.items()},
            {k: v.copy() for k, v in self.node_attr.items()},
            self.masks,
            None if self._members is None else {k: v.copy() for k, v in self._members.items()},
            self.level,
            dict(self.meta),
        )

    # -------------------------------------------------------------- validation
    def validate(self) -> None:
        """Check every array against the data model.

        Raises
        ------
        GraphValidationError
            With a message naming the value found, e.g.
            "expected edge_index of shape [2, E] (got [3, 10])".

        Examples
        --------
        >>> g = CorrespondenceGraph(2, edge_index=[[0], [1]], edge_attr={"weight": [1.0, 2.0]})
        >>> g.validate()
        Traceback (most recent call last):
        ...
        graphseg.graphs.graph.GraphValidationError: expected edge_attr['weight'] of length E=1 (got 2)
        """
        if self.num_nodes < 0:
            raise GraphValidationError(f"expected num_nodes >= 0 (got {self.num_nodes})")
        if self.level not in ("mask", "super"):
            raise GraphValidationError(f"expected level 'mask' or 'super' (got {self.level!r})")
        as_edge_index(self.edge_index, self.num_nodes)
        if self.edge_index.dtype != np.int64:
            raise GraphValidationError(f"expected edge_index of dtype int64 (got {self.edge_index.dtype})")
        e = self.num_edges
        for name, col in self.edge_attr.items():
            if col.ndim < 1 or col.shape[0] != e:
                raise GraphValidationError(
                    f"expected edge_attr[{name!r}] of length E={e} (got {col.shape[0] if col.ndim else 'a scalar'})"
                )
        if "criterion" in self.edge_attr and self.edge_attr["criterion"].dtype.kind not in "UO":
            raise GraphValidationError(
                f"expected edge_attr['criterion'] of str dtype (got {self.edge_attr['criterion'].dtype})"
            )
        for name, col in self.node_attr.items():
            if col.ndim < 1 or col.shape[0] != self.num_nodes:
                raise GraphValidationError(
                    f"expected node_attr[{name!r}] of length num_nodes={self.num_nodes} "
                    f"(got {col.shape[0] if col.ndim else 'a scalar'})"
                )
        for name, width in (("bbox", 4), ("centroid", 2), ("centroid_3d", 3), ("bbox_3d", 6)):
            vec = self.node_attr.get(name)
            if vec is not None and (vec.ndim != 2 or vec.shape[1] != width):
                raise GraphValidationError(
                    f"expected node_attr[{name!r}] of shape [N, {width}] (got {list(vec.shape)})"
                )
        if self.masks is not None:
            for v, m in enumerate(self.masks):
                if m.ndim != 2 or not np.issubdtype(m.dtype, np.integer):
                    raise GraphValidationError(
                        f"expected masks[{v}] as an integer label image [H, W] (got {m.dtype} {list(m.shape)})"
                    )
        mem = self.members
        n = mem["node"].shape[0]
        for key in ("view", "mask_id"):
            if mem[key].shape != (n,):
                raise GraphValidationError(f"expected members[{key!r}] of shape [{n}] (got {list(mem[key].shape)})")
        if n and (mem["node"].min() < 0 or mem["node"].max() >= self.num_nodes):
            raise GraphValidationError(
                f"expected members['node'] in [0, num_nodes={self.num_nodes}) (got {int(mem['node'].max())})"
            )

    # ------------------------------------------------------------------- nodes
    def node(self, i: int) -> MaskNode | SuperNode:
        """Row ``i`` of the node table as a :class:`MaskNode` or :class:`SuperNode`."""
        if not 0 <= i < self.num_nodes:
            raise IndexError(f"node {i} out of range [0, {self.num_nodes})")
        row = {k: v[i] for k, v in self.node_attr.items()}

        def tup(x: Any, cast: type) -> Any:
            return None if x is None else tuple(cast(t) for t in np.atleast_1d(x))

        if self.level == "mask":
            return MaskNode(
                view=int(row["view"]),
                mask_id=int(row["mask_id"]),
                area=int(row["area"]),
                bbox=tup(row["bbox"], int),
                centroid=tup(row["centroid"], float),
                num_points=None if "num_points" not in row else int(row["num_points"]),
                centroid_3d=tup(row.get("centroid_3d"), float),
                bbox_3d=tup(row.get("bbox_3d"), float),
            )
        extra = {k: v for k, v in row.items() if k not in ("component", "member_count", "area")}
        return SuperNode(
            component=int(row.get("component", i)),
            member_count=int(row.get("member_count", 1)),
            area=int(row.get("area", 0)),
            extra=extra,
        )

    def nodes(self) -> Iterator[MaskNode | SuperNode]:
        """Iterate over :meth:`node` rows."""
        for i in range(self.num_nodes):
            yield self.node(i)

    def node_labels(self) -> list[np.ndarray]:
        """Per-view int64 images mapping each pixel to its node (-1 = none).

        Needs :attr:`masks`. O(total pixels).
        """
        if self.masks is None:
            raise GraphValidationError("this graph stores no masks; node_labels() needs them")
        mem = self.members
        out = []
        for v, lab in enumerate(self.masks):
            sel = mem["view"] == v
            size = int(lab.max()) + 1 if lab.size else 1
            size = max(size, int(mem["mask_id"][sel].max()) + 2 if sel.any() else 1)
            lut = np.full(size, -1, np.int64)
            lut[mem["mask_id"][sel] + 1] = mem["node"][sel]
            out.append(lut[lab])
        return out

    # ------------------------------------------------------------------- edges
    def add_edges(
        self,
        edge_index: Any,
        edge_attr: Mapping[str, Any] | None = None,
        *,
        in_place: bool = False,
    ) -> CorrespondenceGraph:
        """Append edges with their attributes; absent columns are filled.

        Parameters
        ----------
        edge_index : array_like
            int ``[2, E']``.
        edge_attr : mapping, optional
            Columns of length ``E'``.
        in_place : bool
            Modify this graph instead of returning a new one.

        Examples
        --------
        >>> g = CorrespondenceGraph(3)
        >>> g2 = g.add_edges([[0], [2]], {"criterion": ["chamfer_3d"], "weight": [0.1]})
        >>> g.num_edges, g2.num_edges, g2.edge_attr["criterion"].tolist()
        (0, 1, ['chamfer_3d'])
        """
        ei = as_edge_index(edge_index, self.num_nodes)
        attrs = {k: np.asarray(v) for k, v in (edge_attr or {}).items()}
        for name, col in attrs.items():
            if col.shape[:1] != (ei.shape[1],):
                raise GraphValidationError(
                    f"expected edge_attr[{name!r}] of length E={ei.shape[1]} (got {col.shape[0] if col.ndim else 'a scalar'})"
                )
        target = self if in_place else self.copy()
        target.edge_attr = concat_edge_attr([(target.num_edges, target.edge_attr), (ei.shape[1], attrs)])
        target.edge_index = np.concatenate([target.edge_index, ei], axis=1)
        return target

    # -------------------------------------------------------------- contraction
    def contract(self, contractor: Any = "star", *, rng: Any = None) -> np.ndarray:
        """Cluster vector ``[N]`` of this graph's components (see :mod:`.contract`).

        Repulsive edges (``sign < 0``) are never merged across: signed
        contractors honour them as cannot-links, plain ones ignore them
        (:func:`graphseg.graphs.contractor.run_contractor`, the same path as
        :func:`graphseg.method.segment`).
        """
        from .contractor import run_contractor
        from .registry import contractors

        c = contractors.resolve(contractor)
        return run_contractor(c, self.edge_index, self.num_nodes, edge_attr=self.edge_attr, node_attr=self.node_attr, rng=rng)
